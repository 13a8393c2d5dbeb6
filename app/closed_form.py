"""Closed-form solutions the results are checked against (METHOD.md section 6).

All functions are plain numpy. Plane strain uses E' = E / (1 - nu^2), nu' = nu / (1 - nu).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike


def effective_moduli(E: float, nu: float, plane: str) -> tuple[float, float]:
    """(E, nu) to use in plane-stress formulas for plane "strain" or "stress" (another
    name, e.g. "plane_strain", is a ValueError: it read as plane stress before)."""
    if plane == "strain":
        return E / (1.0 - nu**2), nu / (1.0 - nu)
    if plane != "stress":
        raise ValueError(f"plane = {plane!r}: use 'strain' or 'stress'")
    return E, nu


def timoshenko_cantilever(x: ArrayLike, y: ArrayLike, *, P: float, L: float, D: float,
                          E: float, nu: float, plane: str = "strain",
                          thickness: float = 1.0) -> dict:
    """Timoshenko & Goodier cantilever: 0 <= x <= L, -D/2 <= y <= D/2, clamped at x = 0,
    parabolic shear traction of resultant P (downward) at x = L.

    Returns displacement ux, uy at (x, y), the tip deflection uy(L, 0) and the strain
    energy U of the beam (thickness included).
    """
    e, n = effective_moduli(E, nu, plane)
    inertia = D**3 / 12.0
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    p = P / thickness
    ux = p * y / (6 * e * inertia) * ((6 * L - 3 * x) * x + (2 + n) * (y**2 - D**2 / 4))
    uy = -p / (6 * e * inertia) * (3 * n * y**2 * (L - x) + (4 + 5 * n) * D**2 * x / 4
                                   + (3 * L - x) * x**2)
    tip = -(p * L**3 / (3 * e * inertia) + (4 + 5 * n) * p * L * D**2 / (24 * e * inertia))
    g = e / (2 * (1 + n))
    energy = thickness * (p**2 * L**3 / (6 * e * inertia) + 3 * p**2 * L / (5 * g * D))
    return {"ux": ux, "uy": uy, "tip_deflection": tip, "strain_energy": energy}


def hertz_cylinder(P: float, R: float, E1: float, nu1: float, E2: float, nu2: float,
                   thickness: float = 1.0) -> dict:
    """Hertz line contact of a cylinder (radius R) on a flat, plane strain.

    P is the total force (per `thickness`). Returns E*, the half-width a and the peak
    pressure p0.
    """
    e_star = 1.0 / ((1 - nu1**2) / E1 + (1 - nu2**2) / E2)
    a, p0 = hertz_contact(P / thickness, R, e_star)
    return {"E_star": e_star, "a": a, "p0": p0}


def hertz_contact(p: float, R: float, E_star: float) -> tuple[float, float]:
    """Hertz half-width a = sqrt(4 p R / (pi E*)) and peak p0 = 2 p / (pi a) for a line
    load p (force per unit thickness) on a cylinder of radius R."""
    a = float(np.sqrt(4 * p * R / (np.pi * E_star)))
    return a, 2 * p / (np.pi * a)


def hertz_pressure(x: ArrayLike, a: float, p0: float) -> np.ndarray:
    """p(x) = p0 sqrt(1 - x^2 / a^2) inside |x| < a, 0 outside."""
    x = np.asarray(x, dtype=float)
    return p0 * np.sqrt(np.clip(1.0 - (x / a) ** 2, 0.0, None))


def cattaneo_traction(x: ArrayLike, a: float, p0: float, mu: float,
                      Q_over_muP: float) -> np.ndarray:
    """Cattaneo-Mindlin tangential traction magnitude for a tangential load Q < mu P.

    Stick half-width c = a sqrt(1 - Q / (mu P)); q(x) = mu p0 [sqrt(1 - x^2/a^2)
    - (c/a) sqrt(1 - x^2/c^2)] in |x| < c and mu p(x) in c <= |x| < a (everywhere, c = 0,
    for Q >= mu P).
    """
    x = np.asarray(x, dtype=float)
    c = stick_half_width(a, Q_over_muP)
    outer = mu * hertz_pressure(x, a, p0)
    inner = mu * p0 * (c / a) * np.sqrt(np.clip(1.0 - (x / c) ** 2, 0.0, None)) if c > 0 else 0
    return outer - inner


def stick_half_width(a: float, Q_over_muP: float) -> float:
    """Cattaneo-Mindlin stick-zone half-width c = a sqrt(1 - Q / (mu P)); 0 for Q >= mu P."""
    return float(a * np.sqrt(max(1.0 - Q_over_muP, 0.0)))


GROSS_SLIP_TOL = 1e-8
"""|Q| within this fraction of mu P is gross slip (the run's |Q| never exceeds mu P but by
round-off, to either side)."""


def _edges_from_states(x: np.ndarray, inside: np.ndarray) -> tuple[float, float]:
    """Left/right edges of the zone where `inside` holds, as midpoints between the last
    pair inside and the first pair outside on each side (x sorted ascending)."""
    idx = np.flatnonzero(inside)
    if idx.size == 0:
        return float("nan"), float("nan")
    lo, hi = idx[0], idx[-1]
    left = 0.5 * (x[lo] + x[lo - 1]) if lo > 0 else x[lo]
    right = 0.5 * (x[hi] + x[hi + 1]) if hi + 1 < x.size else x[hi]
    return float(left), float(right)


INTERPOLATED_L2_RANGE = 1.5
"""The interpolated L2 errors integrate over |x - x0| <= INTERPOLATED_L2_RANGE x a_Hertz."""


def interpolated_l2_rel_error(x: ArrayLike, values: ArrayLike,
                              exact: Callable[[np.ndarray], np.ndarray], half_range: float, *,
                              n_samples: int = 20001) -> float:
    """L2 error of a pair profile against a closed form, the definition CalculiX results
    are quoted in (../shared/design/CALCULIX-NOTES.md).

    x: (m,) pair positions relative to the contact centre (length); values: (m,) traction
    at those pairs; exact: callable giving the closed-form traction at given positions.
    The pair values are interpolated linearly between pairs (sorted by x; constant beyond
    the outermost pairs) and compared with `exact` over |x| <= half_range, by the
    trapezoid rule on `n_samples` equidistant points. Returns ||f_h - f|| / ||f||.
    """
    o = np.argsort(x)
    xs = np.linspace(-half_range, half_range, n_samples)
    fh = np.interp(xs, np.asarray(x, dtype=float)[o], np.asarray(values, dtype=float)[o])
    fe = np.asarray(exact(xs), dtype=float)
    num = np.trapz((fh - fe) ** 2, xs)
    den = np.trapz(fe**2, xs)
    return float(np.sqrt(num / den)) if den > 0 else float("nan")


def hertz_errors(x: ArrayLike, p: ArrayLike, length: ArrayLike, *, P: float, R: float,
                 E_star: float, x0: float = 0.0, thickness: float = 1.0) -> dict:
    """Compare a computed pressure p(x) (traction, per pair) with Hertz.

    Half-width: the contact edges are the midpoints between the last loaded and the
    first open pair on each side. L2 error of p over |x - x0| < a_H, weighted by the
    pairs' tributary lengths, relative to the L2 norm of the Hertz pressure
    (`pressure_l2_rel_error`); `pressure_l2_interp_rel_error` is the interpolated one
    (see `interpolated_l2_rel_error`).
    """
    o = np.argsort(x)
    x, p, length = np.asarray(x)[o] - x0, np.asarray(p)[o], np.asarray(length)[o]
    if not P > 0.0:  # nothing pressed (unloaded, lifted off): no Hertz contact to compare
        nan = float("nan")
        return {"P": P, "a_hertz": nan, "p0_hertz": nan, "p_max": float(p.max(initial=0.0)),
                "p_max_rel_error": nan, "half_width": nan, "half_width_rel_error": nan,
                "contact_edges": [nan, nan], "pressure_l2_rel_error": nan,
                "pressure_l2_interp_rel_error": nan, "pressure_l2_interp_floor": nan}
    a, p0 = hertz_contact(P / thickness, R, E_star)
    left, right = _edges_from_states(x, p > 1e-9 * max(p.max(), 1e-300))
    half = 0.5 * (right - left)
    zone = np.abs(x) < a
    ph = hertz_pressure(x, a, p0)
    l2 = np.sqrt(np.sum(length[zone] * (p[zone] - ph[zone]) ** 2)
                 / np.sum(length[zone] * ph[zone] ** 2))
    return {"P": P, "a_hertz": a, "p0_hertz": p0, "p_max": float(p.max()),
            "p_max_rel_error": float(abs(p.max() - p0) / p0), "half_width": half,
            "half_width_rel_error": float(abs(half - a) / a),
            "contact_edges": [left + x0, right + x0], "pressure_l2_rel_error": float(l2),
            "pressure_l2_interp_rel_error": interpolated_l2_rel_error(
                x, p, lambda s: hertz_pressure(s, a, p0), INTERPOLATED_L2_RANGE * a),
            # the same error of the exact pressure sampled at the pairs: what the
            # interpolated definition cannot resolve at this pair spacing (edge kinks)
            "pressure_l2_interp_floor": interpolated_l2_rel_error(
                x, hertz_pressure(x, a, p0), lambda s: hertz_pressure(s, a, p0),
                INTERPOLATED_L2_RANGE * a)}


def cattaneo_errors(x: ArrayLike, p: ArrayLike, q: ArrayLike, length: ArrayLike,
                    stick: ArrayLike, *, P: float, Q: float, mu: float, R: float,
                    E_star: float, x0: float = 0.0, thickness: float = 1.0) -> dict:
    """Compare the stick zone and q(x) with Cattaneo-Mindlin (|q| is compared).

    stick: (m,) bool, pairs in contact that did not slip in the last step (none: a stick
    half-width of 0). |Q| within GROSS_SLIP_TOL of mu P is gross slip: c = 0, q = mu p, and
    the stick zone's relative error is NaN (against 0); |Q| above mu P (a bond's strength
    adds to friction) has no closed form: NaN errors and a `note`.
    `traction_l2_rel_error` is weighted by tributary lengths over |x| < a;
    `traction_l2_interp_rel_error` is the interpolated one (`interpolated_l2_rel_error`).
    """
    o = np.argsort(x)
    x, q, length = np.asarray(x)[o] - x0, np.asarray(q)[o], np.asarray(length)[o]
    stick = np.asarray(stick)[o]
    a, p0 = hertz_contact(P / thickness, R, E_star)
    ratio = abs(Q) / (mu * P)
    nan = float("nan")
    if ratio > 1.0 + GROSS_SLIP_TOL:
        return {"P": P, "Q": Q, "Q_over_muP": ratio, "a_hertz": a, "stick_half_width": nan,
                "stick_half_width_exact": nan, "stick_half_width_rel_error": nan,
                "stick_edges": [nan, nan], "traction_l2_rel_error": nan,
                "traction_l2_interp_rel_error": nan,
                "note": f"|Q| / (mu P) = 1 + {ratio - 1.0:.3g}: more than friction holds the "
                        "contact (a bond's strength?), no Cattaneo-Mindlin closed form"}
    r = 1.0 if ratio >= 1.0 - GROSS_SLIP_TOL else ratio  # round-off about mu P: gross slip
    c_exact = stick_half_width(a, r)
    left, right = _edges_from_states(x, stick)
    half = 0.5 * (right - left) if stick.any() else 0.0
    zone = np.abs(x) < a
    qc = cattaneo_traction(x, a, p0, mu, r)
    l2 = np.sqrt(np.sum(length[zone] * (np.abs(q[zone]) - qc[zone]) ** 2)
                 / np.sum(length[zone] * qc[zone] ** 2))
    return {"P": P, "Q": Q, "Q_over_muP": ratio, "a_hertz": a,
            "stick_half_width": half, "stick_half_width_exact": c_exact,
            "stick_half_width_rel_error": float(abs(half - c_exact) / c_exact)
            if c_exact > 0 else nan,
            "stick_edges": [left + x0, right + x0], "traction_l2_rel_error": float(l2),
            "traction_l2_interp_rel_error": interpolated_l2_rel_error(
                x, np.abs(q), lambda s: cattaneo_traction(s, a, p0, mu, r),
                INTERPOLATED_L2_RANGE * a)}
