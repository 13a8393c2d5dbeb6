"""Hertz line contact of a cylinder on a flat: peak pressure, half-width, L2 of p(x)."""

from __future__ import annotations

import numpy as np

from app.closed_form import hertz_errors, hertz_pressure
from app.errors import InputError
from app.references.base import Reference, RunFigures


def pressure_errors(params: dict, run: RunFigures) -> dict:
    """The `hertz` entry: p(x) of the first interface against Hertz at its total force."""
    c = run.contact
    x0 = params["center_x"]
    # the along-y check first: it is the cause when center_x is off the x span, too
    if c.y is not None and len(c.x) > 1 and float(np.ptp(c.y)) > float(np.ptp(c.x)):
        raise InputError(f"[reference] measures p along x, but interface '{c.interface}' runs "
                         f"along y (its pairs span x = {np.min(c.x):.4g} to {np.max(c.x):.4g}, "
                         f"y = {np.min(c.y):.4g} to {np.max(c.y):.4g}): lay the contact along "
                         "x, or leave [reference] out")
    # round-off of the pair coordinates is inside (one pair at x = -1.8e-16 and x0 = 0 failed
    # the run after its last step); 1e308 overflowed the contact edges to -inf before
    tol = 1e-9 * max(float(np.ptp(c.x)), float(np.abs(c.x).max()), params["radius"]) \
        if len(c.x) else 0.0
    if len(c.x) and not float(np.min(c.x)) - tol <= x0 <= float(np.max(c.x)) + tol:
        raise InputError(f"reference.center_x = {x0:g} lies outside interface "
                         f"'{c.interface}', whose pairs span x = {np.min(c.x):.4g} to "
                         f"{np.max(c.x):.4g}: the contact centre must be on the interface")
    return {"interface": c.interface, "center_x": params["center_x"],
            "hertz": hertz_errors(c.x, c.p, c.length, P=float(c.p_force.sum()),
                                  R=params["radius"], E_star=c.E_star,
                                  x0=params["center_x"], thickness=run.thickness)}


def pressure_overlay(ref: dict, mu: float) -> dict:
    """Hertz's p(x) for the contact plots, from a summary's `reference` entry."""
    h, x0 = ref["hertz"], ref.get("center_x", 0.0)
    return {"p": ("Hertz", lambda x: hertz_pressure(x - x0, h["a_hertz"], h["p0_hertz"]))}


REFERENCE = Reference(
    name="hertz",
    keys={"radius": None, "center_x": 0.0},
    positive=("radius",),
    errors=pressure_errors,
    columns=((("hertz", "p_max_rel_error"), "peak_pressure"),
             (("hertz", "half_width_rel_error"), "half_width"),
             (("hertz", "pressure_l2_rel_error"), "pressure_l2"),
             (("hertz", "pressure_l2_interp_rel_error"), "pressure_l2_interp")),
    overlay=pressure_overlay,
    needs_contact=True,
)
