"""Hertz line contact of a cylinder on a flat: peak pressure, half-width, L2 of p(x)."""

from __future__ import annotations

import numpy as np

from app.closed_form import hertz_errors, hertz_pressure
from app.errors import InputError
from app.references.base import ContactProfile, Reference, RunFigures

STRAIGHT_SINE = 0.25
"""A contact is near-straight when every loaded pair's tangent is within asin(0.25) (14.5
deg) of the contact's direction; a curved one has no line to measure on. Node-to-segment
pairs carry the master's tangents, the arc's own where the cylinder is the master (at
sin = a/R at the edges): asin(0.1) refused hertz.toml swapped at a/R = 0.108 (6.2 deg),
the shipped a/R being 0.1."""


def line_direction(tangent: np.ndarray, length: np.ndarray, p: np.ndarray
                   ) -> tuple[np.ndarray, float]:
    """(t, sine): the contact's own direction t (2,), the loaded (p > 0; all without any)
    pairs' unit tangents (m, 2) averaged with their lengths (m,) and pointed towards +x
    (+y for a contact along y, |t_x| <= 1e-12), so that an untilted scene reads t = (1, 0)
    exactly, and the largest |sin| of the angle between a loaded pair's tangent and t (0
    without any: an unloaded contact has no shape to judge, and its errors are NaN).
    The closed forms are even in s, so the errors do not depend on t's sign."""
    loaded = bool(np.any(p > 0))
    on = p > 0 if loaded else np.ones(len(p), bool)
    tv = (length[on, None] * tangent[on]).sum(axis=0)
    if not np.hypot(*tv) > 0:
        tv = tangent[on].sum(axis=0)
    t = tv / np.hypot(*tv)
    if t[0] < -1e-12 or (abs(t[0]) <= 1e-12 and t[1] < 0):
        t = -t
    if not loaded:
        return t, 0.0
    return t, float(np.abs(tangent[on, 0] * t[1] - tangent[on, 1] * t[0]).max())


def contact_direction(c: ContactProfile) -> np.ndarray | None:
    """t (2,) of `line_direction`; None when the pairs' tangents are not known.
    InputError for a contact that is not near-straight (STRAIGHT_SINE)."""
    if c.tangent is None or len(c.x) == 0:
        return None
    t, turn = line_direction(c.tangent, c.length, c.p)
    if turn > STRAIGHT_SINE:
        raise InputError(
            f"[reference] measures p along the contact, but interface '{c.interface}' is not "
            f"near-straight where it is loaded (its pairs' tangents turn by up to "
            f"{np.degrees(np.arcsin(min(turn, 1.0))):.3g} deg from their mean, "
            f"above {np.degrees(np.arcsin(STRAIGHT_SINE)):.3g}): leave [reference] out")
    return t


def along_contact(params: dict, c: ContactProfile) -> np.ndarray:
    """s (m,): the pairs' coordinates along the contact's direction t from its centre C,
    s = (X - C).t. C = (center_x, center_y); without center_y, the point of the contact
    line (through the loaded pairs' mean position, along t) at x = center_x. An untilted
    scene (t = (1, 0)) reads s = x - center_x exactly. InputError for a contact that is not
    near-straight, or one turned over 60 deg from x without center_y."""
    x0, y0 = params["center_x"], params.get("center_y")
    t = contact_direction(c)
    if t is None or c.y is None:  # no tangents: along x, refusing a contact along y
        if c.y is not None and len(c.x) > 1 and float(np.ptp(c.y)) > float(np.ptp(c.x)):
            raise InputError(f"[reference] measures p along x, but interface '{c.interface}'"
                             " runs along y and its pairs' tangents are not known: lay the "
                             "contact along x, or leave [reference] out")
        return c.x - x0
    if y0 is None:
        if abs(t[0]) < 0.5:
            raise InputError(
                f"[reference] interface '{c.interface}' runs at "
                f"{np.degrees(np.arctan2(t[1], t[0])):.3g} deg from x: name its centre with "
                "reference.center_y (and center_x), a point of the contact line")
        on = c.p > 0 if np.any(c.p > 0) else np.ones(len(c.x), bool)
        w = c.length[on] if c.length[on].sum() > 0 else np.ones(int(on.sum()))
        mx, my = (float(np.average(v[on], weights=w)) for v in (c.x, c.y))
        y0 = my + (x0 - mx) * t[1] / t[0]
    return (c.x - x0) * t[0] + (c.y - y0) * t[1]


def pressure_errors(params: dict, run: RunFigures) -> dict:
    """The `hertz` entry: p of the first interface along the contact's own direction (see
    `along_contact`) against Hertz at the pairs' total normal force; `contact_edges` are
    center_x + s (x itself on an untilted scene)."""
    c = run.contact
    s = along_contact(params, c)
    # round-off of the pair coordinates is inside (one pair at x = -1.8e-16 and x0 = 0 failed
    # the run after its last step); 1e308 overflowed the contact edges to -inf before
    x0 = params["center_x"]
    xs = s + x0 if len(s) else s
    tol = 1e-9 * max(float(np.ptp(xs)), float(np.abs(xs).max()), params["radius"]) \
        if len(s) else 0.0
    if len(s) and not float(np.min(s)) - tol <= 0.0 <= float(np.max(s)) + tol:
        raise InputError(f"reference.center_x = {x0:g}"
                         + (f", center_y = {params['center_y']:g}"
                            if params.get("center_y") is not None else "")
                         + f" lies outside interface '{c.interface}', whose pairs span "
                         f"{np.min(s):.4g} to {np.max(s):.4g} from it along the contact: "
                         "the contact centre must be on the interface")
    h = hertz_errors(s, c.p, c.length, P=float(c.p_force.sum()), R=params["radius"],
                     E_star=c.E_star, thickness=run.thickness)
    h["contact_edges"] = [e + x0 for e in h["contact_edges"]]
    # center_y only when given: the plots' coordinate along a tilted contact needs it
    cy = {} if params.get("center_y") is None else {"center_y": params["center_y"]}
    return {"interface": c.interface, "center_x": x0} | cy | {"hertz": h}


def pressure_overlay(ref: dict, mu: float) -> dict:
    """Hertz's p(x) for the contact plots, from a summary's `reference` entry."""
    h, x0 = ref["hertz"], ref.get("center_x", 0.0)
    return {"p": ("Hertz", lambda x: hertz_pressure(x - x0, h["a_hertz"], h["p0_hertz"]))}


REFERENCE = Reference(
    name="hertz",
    keys={"radius": None, "center_x": 0.0, "center_y": None},
    positive=("radius",),
    optional=("center_y",),
    errors=pressure_errors,
    columns=((("hertz", "p_max_rel_error"), "peak_pressure"),
             (("hertz", "half_width_rel_error"), "half_width"),
             (("hertz", "pressure_l2_rel_error"), "pressure_l2"),
             (("hertz", "pressure_l2_interp_rel_error"), "pressure_l2_interp")),
    overlay=pressure_overlay,
    needs_contact=True,
)
