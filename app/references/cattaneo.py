"""Cattaneo-Mindlin partial slip under a tangential load Q < mu P: stick zone and q(x)."""

from __future__ import annotations

import math

import numpy as np

from app.closed_form import GROSS_SLIP_TOL, cattaneo_errors, cattaneo_traction
from app.references.base import Reference, RunFigures
from app.references.hertz import along_contact, pressure_errors, pressure_overlay


def _errors(params: dict, run: RunFigures) -> dict:
    out = pressure_errors(params, run)
    c = run.contact
    # the pairs' normal and tangential forces: the resultants in the contact's frame
    P, Q = float(c.p_force.sum()), float(c.q_force.sum())
    if c.mu <= 0.0 or P <= 0.0:  # no friction bound to compare with
        out["cattaneo"] = {"P": P, "Q": Q, "Q_over_muP": math.nan,
                           "stick_half_width_rel_error": math.nan,
                           "traction_l2_rel_error": math.nan,
                           "traction_l2_interp_rel_error": math.nan}
        return out
    # along the contact's own direction, as p (q is signed along the pairs' tangents)
    ca = cattaneo_errors(along_contact(params, c), c.p, c.q, c.length, c.stick, P=P, Q=Q,
                         mu=c.mu, R=params["radius"], E_star=c.E_star,
                         thickness=run.thickness)
    if "stick_edges" in ca:
        ca["stick_edges"] = [e + params["center_x"] for e in ca["stick_edges"]]
    out["cattaneo"] = ca
    return out


def _overlay(ref: dict, mu: float) -> dict:
    curves = pressure_overlay(ref, mu)
    h, ca = ref["hertz"], ref["cattaneo"]
    # |Q| above mu P (a bond's strength added): no closed form, as in the errors' `note`
    if ca.get("Q_over_muP", math.nan) <= 1.0 + GROSS_SLIP_TOL:
        sign = float(np.sign(ca["Q"])) or 1.0
        x0 = ref.get("center_x", 0.0)
        curves["q"] = ("Cattaneo-Mindlin", lambda x: sign * cattaneo_traction(
            x - x0, h["a_hertz"], h["p0_hertz"], mu, ca["Q_over_muP"]))
    return curves


REFERENCE = Reference(
    name="cattaneo",
    keys={"radius": None, "center_x": 0.0, "center_y": None},
    positive=("radius",),
    optional=("center_y",),
    errors=_errors,
    columns=((("hertz", "p_max_rel_error"), "peak_pressure"),
             (("hertz", "pressure_l2_rel_error"), "pressure_l2"),
             (("hertz", "pressure_l2_interp_rel_error"), "pressure_l2_interp"),
             (("cattaneo", "stick_half_width_rel_error"), "stick_zone"),
             (("cattaneo", "traction_l2_rel_error"), "traction_l2"),
             (("cattaneo", "traction_l2_interp_rel_error"), "traction_l2_interp")),
    overlay=_overlay,
    needs_contact=True,
)
