"""Cattaneo-Mindlin partial slip under a tangential load Q < mu P: stick zone and q(x)."""

from __future__ import annotations

import math

import numpy as np

from app.closed_form import GROSS_SLIP_TOL, cattaneo_errors, cattaneo_traction
from app.references.base import Reference, RunFigures
from app.references.hertz import pressure_errors, pressure_overlay


def _errors(params: dict, run: RunFigures) -> dict:
    out = pressure_errors(params, run)
    c = run.contact
    P, Q = float(c.p_force.sum()), float(c.q_force.sum())
    if c.mu <= 0.0 or P <= 0.0:  # no friction bound to compare with
        out["cattaneo"] = {"P": P, "Q": Q, "Q_over_muP": math.nan,
                           "stick_half_width_rel_error": math.nan,
                           "traction_l2_rel_error": math.nan,
                           "traction_l2_interp_rel_error": math.nan}
        return out
    out["cattaneo"] = cattaneo_errors(c.x, c.p, c.q, c.length, c.stick, P=P, Q=Q, mu=c.mu,
                                      R=params["radius"], E_star=c.E_star,
                                      x0=params["center_x"], thickness=run.thickness)
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
    keys={"radius": None, "center_x": 0.0},
    positive=("radius",),
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
