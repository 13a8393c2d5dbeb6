"""Where the Hertz L2(p) error of a pair profile sits: the contact core, the pairs next to
the contact edges, and the floors of the two L2 definitions (README, issue 11).

The tributary definition (closed_form.hertz_errors, `pressure_l2_rel_error`) compares
each pair's p with the Hertz pressure *at* the pair over |x| < a, weighted by tributary
length: the exact pressure sampled at the pairs scores 0. A dual-mortar nodal pressure is
a force over the tributary length, i.e. an average over the tributary; the exact Hertz
average over each pair's tributary (`hertz_tributary_average`) scores `average_floor`,
which near the edge (p ~ sqrt(a - |x|)) is O(h) and depends on where x = +-a falls
between the pairs. `interpolated_l2_best` bounds the interpolated definition from below.
Plain numpy and scipy.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.optimize import least_squares, lsq_linear

from app.closed_form import hertz_pressure, interpolated_l2_rel_error


def _sqrt_integral(s: np.ndarray) -> np.ndarray:
    """Antiderivative of sqrt(1 - s^2), constant outside [-1, 1]."""
    s = np.clip(s, -1.0, 1.0)
    return 0.5 * (s * np.sqrt(1.0 - s * s) + np.arcsin(s))


def tributary_bounds(x: np.ndarray) -> np.ndarray:
    """(m + 1,) tributary bounds of sorted pair positions x (m,): midpoints between
    neighbours, the outermost pairs' own positions at the ends."""
    return np.r_[x[0], 0.5 * (x[1:] + x[:-1]), x[-1]]


def hertz_tributary_average(x: np.ndarray, a: float, p0: float) -> np.ndarray:
    """(m,) mean of the Hertz pressure over each pair's tributary (x sorted, relative to
    the contact centre); a zero-length tributary gets the point value."""
    b = tributary_bounds(x)
    width = b[1:] - b[:-1]
    mean = p0 * a * (_sqrt_integral(b[1:] / a) - _sqrt_integral(b[:-1] / a)) / np.where(
        width > 0, width, 1.0)
    return np.where(width > 0, mean, hertz_pressure(x, a, p0))


def tributary_l2(length: np.ndarray, f: np.ndarray, g: np.ndarray, zone: np.ndarray
                 ) -> float:
    """||f - g|| / ||g|| over the pairs in `zone` (bool, (m,)), weighted by their
    tributary lengths (m,)."""
    return float(np.sqrt(np.sum(length[zone] * (f[zone] - g[zone]) ** 2)
                         / np.sum(length[zone] * g[zone] ** 2)))


def pressure_breakdown(x: np.ndarray, p: np.ndarray, length: np.ndarray, a: float,
                       p0: float, core: float = 0.95) -> dict:
    """Tributary L2(p) against Hertz (x relative to the contact centre, any order) split
    into the core |x| < core a and the edge pairs core a <= |x| < a (both relative to the
    same ||p_H||, so total^2 = core^2 + edge^2); the worst pair in |x| < a (x / a and
    (p - p_H) / p0); loaded_outside, the pairs with p > 0 at |x| >= a (left out of the
    tributary L2); odd_even_over_p0, the median over the pairs in |x| < a/2 of
    |e_i - (e_(i-1) + e_(i+1)) / 2| / 2 with e = (p - p_H) / p0 (the amplitude A of an
    alternation +-A from pair to pair; about 0 for a smooth error); and average_floor, the
    same L2 of the exact tributary averages."""
    o = np.argsort(x)
    x, p, length = np.asarray(x, float)[o], np.asarray(p, float)[o], np.asarray(length)[o]
    ph = hertz_pressure(x, a, p0)
    zone = np.abs(x) < a
    inner = zone & (np.abs(x) < core * a)
    den = np.sum(length[zone] * ph[zone] ** 2)

    def l2(sel, f):
        return float(np.sqrt(np.sum(length[sel] * (f[sel] - ph[sel]) ** 2) / den))

    err = np.where(zone, (p - ph) / p0, 0.0)
    k = int(np.argmax(np.abs(err)))
    total, in_core = l2(zone, p), l2(inner, p)
    mid = np.flatnonzero(np.abs(x) < 0.5 * a)
    mid = mid[(mid > 0) & (mid < x.size - 1)]
    wiggle = np.abs(err[mid] - 0.5 * (err[mid - 1] + err[mid + 1])) / 2
    return {"l2": total, "l2_core": in_core, "l2_edge": float(np.sqrt(max(total**2
                                                                          - in_core**2, 0))),
            "worst_x_over_a": float(x[k] / a), "worst_error_over_p0": float(err[k]),
            "odd_even_over_p0": float(np.median(wiggle)) if mid.size else float("nan"),
            "loaded_outside": int(np.sum((p > 0) & ~zone)),
            "average_floor": l2(zone, hertz_tributary_average(x, a, p0))}


def interpolated_l2_best(x: np.ndarray, exact, half_range: float, *,
                         n_samples: int = 20001) -> tuple[float, np.ndarray]:
    """The smallest interpolated L2 error (closed_form.interpolated_l2_rel_error, same
    sampling) that any non-negative pair values can reach at the pair positions x (m,):
    a bounded linear least-squares fit of the linear interpolant between pairs (constant
    beyond the outermost ones) to `exact` over |x| <= half_range. Returns (error, the
    best values (m,) in the order of x). A lower bound for every method that reports
    one value per pair at these positions, unlike the floor (the exact values sampled at
    the pairs), which a method can beat.
    """
    x = np.asarray(x, dtype=float)
    o = np.argsort(x)
    xo = x[o]
    xs = np.linspace(-half_range, half_range, n_samples)
    right = np.clip(np.searchsorted(xo, xs), 1, xo.size - 1)
    t = np.clip((xs - xo[right - 1]) / (xo[right] - xo[right - 1]), 0.0, 1.0)
    w = np.full(n_samples, xs[1] - xs[0])  # trapezoid weights
    w[[0, -1]] *= 0.5
    sw = np.sqrt(w)
    rows = np.tile(np.arange(n_samples), 2)
    interp = sp.csr_matrix((np.r_[(1 - t) * sw, t * sw], (rows, np.r_[right - 1, right])),
                           shape=(n_samples, xo.size))
    used = np.unique(interp.indices[interp.data > 0])
    fit = lsq_linear(interp[:, used], np.asarray(exact(xs), dtype=float) * sw,
                     bounds=(0.0, np.inf), tol=1e-12)
    best = np.zeros(xo.size)
    best[used] = fit.x
    values = np.empty_like(best)
    values[o] = best
    return interpolated_l2_rel_error(x, values, exact, half_range,
                                     n_samples=n_samples), values


def hertz_form_fit(x: np.ndarray, p: np.ndarray, a: float, p0: float,
                   inside: float = 0.97) -> tuple[float, float]:
    """(p0' / p0 - 1, a' / a - 1): the Hertz-shaped profile p0' sqrt(1 - x^2 / a'^2)
    closest (least squares) to the pair values p (m,) at x (m,, relative to the contact
    centre) over |x| < inside x a, the pairs next to the edges left out. How much more
    peaked and narrower than Hertz a converged profile is (the model error of a finite
    scene)."""
    k = np.abs(x) < inside * a
    fit = least_squares(lambda c: c[0] * np.sqrt(np.clip(1 - (x[k] / c[1]) ** 2, 0, None))
                        - p[k] / p0, [1.0, a])
    return float(fit.x[0] - 1.0), float(fit.x[1] / a - 1.0)
