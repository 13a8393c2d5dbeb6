"""Where a study's field error against the model-free reference sits, and the floor of its
definition (README, issue 11, "Why L2(q), and L2(p) over 1.5 a, have no steady order").

`ref_pressure_l2` / `ref_traction_l2` (app/studies/reference_errors.l2_against) interpolate a
level's pair values f (m,) linearly onto the reference pairs xr (n,) and integrate
(f_h - f_ref)^2 by the trapezoid rule over a window. The trapezoid rule is a weighted sum
over the reference pairs, so the squared error splits exactly into the parts of the
reference pairs that lie in given bands (around the contact edges x = +-a, the stick/slip
boundary +-c, the contact edges of earlier load steps) and the rest (the core):
total^2 = sum of parts^2, each part relative to the same norm. A pair lying in several
bands counts in the first one listed. The floor of the definition is the same error of
the exact field sampled at the level's pairs. Plain numpy.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from app.closed_form import interpolated_l2_rel_error
from app.studies.reference_errors import contact_window, l2_against, observed_order


def trapezoid_weights(x: np.ndarray) -> np.ndarray:
    """(n,) weights w with sum(w * g) == np.trapz(g, x) for sorted x (n,)."""
    x = np.asarray(x, dtype=float)
    w = np.zeros_like(x)
    if x.size >= 2:
        dx = np.diff(x)
        w[:-1] += 0.5 * dx
        w[1:] += 0.5 * dx
    return w


def band_index(xr: np.ndarray, bands: list[np.ndarray], half_width: float) -> np.ndarray:
    """(n,) index of the first band with a centre within half_width (length) of each point
    xr; len(bands) for points in none (the core). bands: centres (any count) per band."""
    idx = np.full(np.asarray(xr).shape, len(bands), dtype=int)
    for k in range(len(bands) - 1, -1, -1):  # first listed wins: assign it last
        c = np.asarray(bands[k], dtype=float).reshape(-1)
        if c.size:
            near = np.min(np.abs(xr[:, None] - c[None, :]), axis=1) <= half_width
            idx[near] = k
    return idx


def field_breakdown(x: np.ndarray, f: np.ndarray, xr: np.ndarray, fr: np.ndarray,
                    window: tuple[float, float], bands: dict[str, np.ndarray],
                    half_width: float) -> dict[str, float]:
    """The error ||f_h - f_ref|| / ||f_ref|| of l2_against (x, xr sorted, lengths) as
    "total" and split into one part per band ({name: centres}, in priority order) plus
    "core"; total^2 equals the sum of the parts^2. NaN if fewer than two reference pairs
    lie in the window."""
    sel = (xr >= window[0]) & (xr <= window[1])
    xs, frs = np.asarray(xr, float)[sel], np.asarray(fr, float)[sel]
    names = [*bands, "core"]
    if xs.size < 2 or np.asarray(x).size < 2:
        return {"total": math.nan} | dict.fromkeys(names, math.nan)
    w = trapezoid_weights(xs)
    den = float(np.sum(w * frs**2))
    sq = w * (np.interp(xs, x, f) - frs) ** 2
    idx = band_index(xs, list(bands.values()), half_width)
    parts = np.bincount(idx, weights=sq, minlength=len(names))
    out = {"total": math.sqrt(float(sq.sum()) / den)}
    return out | {n: math.sqrt(float(v) / den) for n, v in zip(names, parts, strict=True)}


def sampled_floor(x: np.ndarray, xr: np.ndarray, exact: Callable[[np.ndarray], np.ndarray],
                  window: tuple[float, float]) -> float:
    """The l2_against error of the exact field sampled at the level's pairs x against the
    exact field at the reference pairs xr: what the definition reads for a method that is
    exact at its pairs (the interpolation error between the pairs)."""
    x, xr = np.asarray(x, float), np.asarray(xr, float)
    return l2_against(x, exact(x), xr, exact(xr), window)


def orders(errors: list[float]) -> list[float]:
    """Observed orders log2(e_{l-1} / e_l) of successive errors (NaN where not positive)."""
    return [observed_order(a, b) for a, b in zip(errors, errors[1:], strict=False)]


def bisect_pairs(x: np.ndarray, times: int) -> np.ndarray:
    """Sorted pair positions (n,) with a midpoint inserted between every two neighbours,
    `times` times: (2^times (n - 1) + 1,); the pairs of a level split `times` times."""
    x = np.sort(np.asarray(x, dtype=float))
    for _ in range(times):
        x = np.insert(x, np.arange(1, x.size), 0.5 * (x[1:] + x[:-1]))
    return x


def floor_sequence(x0: np.ndarray, exact: Callable[[np.ndarray], np.ndarray],
                   half_range: float, levels: int, ref_levels: int = 1,
                   window: float = 1.5) -> list[dict[str, float]]:
    """Per level l = 0..levels-1 (the pairs x0 (n,) bisected l times; x relative to the
    contact centre): `floor_cf`, the interpolated L2 of the exact field sampled at the
    pairs over |x| <= half_range (closed_form.interpolated_l2_rel_error), and `floor_ref`,
    sampled_floor against the pairs of level l + ref_levels within `window` x the
    half-width of the zone where the exact field is non-zero."""
    out = []
    for lev in range(levels):
        x, xr = bisect_pairs(x0, lev), bisect_pairs(x0, lev + ref_levels)
        win = contact_window(xr, np.abs(exact(xr)), window)
        out.append({"level": lev, "pairs": int(x.size),
                    "floor_cf": interpolated_l2_rel_error(x, exact(x), exact, half_range),
                    "floor_ref": sampled_floor(x, xr, exact, win)})
    return out


def nodal_l2(x: np.ndarray, f: np.ndarray, xr: np.ndarray, fr: np.ndarray,
             window: tuple[float, float]) -> float:
    """||f - f_ref|| / ||f_ref|| at the level's own pairs x (sorted) in window, f_ref
    interpolated linearly at x (on nested levels the pairs x are reference pairs, so no
    interpolation error enters), trapezoid weights over x: a definition whose floor is 0."""
    sel = (x >= window[0]) & (x <= window[1])
    if sel.sum() < 2:
        return math.nan
    xs, w = x[sel], trapezoid_weights(x[sel])
    g = np.interp(xs, xr, fr)
    den = float(np.sum(w * g**2))
    return math.sqrt(float(np.sum(w * (f[sel] - g) ** 2)) / den) if den > 0 else math.nan


def edge_phase(x: np.ndarray, t: float) -> float:
    """Fractional position (t - x_k) / (x_(k+1) - x_k) of the point t in the interval of the
    sorted pairs x (n,) that holds it: where a singular point falls between the pairs
    (on nested levels it follows the doubling map theta -> frac(2 theta)). NaN outside."""
    x = np.asarray(x, dtype=float)
    k = int(np.searchsorted(x, t, side="right")) - 1
    if k < 0 or k >= x.size - 1:
        return math.nan
    return float((t - x[k]) / (x[k + 1] - x[k]))
