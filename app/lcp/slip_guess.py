"""First guess of the twins' stage of the crash (`app.lcp.crash._twin_stage`): which of each
twin pair is active, from a few projected Jacobi sweeps on the pairs' box problem.

Under fixed normal pressures the twins' LCP of a contact LCP is, per pair k with columns
a_k < b_k = twin a_k and x_k = z~_a - z~_b (forward minus backward slip):

    w~_a = (H x)_k + q_a >= 0,   w~_b = -(H x)_k + q_b >= 0,   H = M~[a, a] (SPD),

with z~_a w~_a = z~_b w~_b = 0 (the rows of b are those of a negated). The trial guess
(x = 0: a pair slips where its stick force leaves the cone, q_a < 0 or q_b < 0) misses the
pairs that a neighbour's slip pushes over or relieves; at n = 1500 of the bench_lemke LCP
it is off by 99 of 1000 indices, so the twins' block is factorized twice. Each Jacobi
sweep solves every pair's own row exactly with the others fixed (one product with H, a
view of M when the a_k form a range), and after 10 sweeps that guess is off by 6. It is
only a guess: block pivoting from it finds the stage's exact set, and Lemke checks the
answer.
"""

from __future__ import annotations

import numpy as np

from app.lcp.scaling import ScaledM, gather

SWEEPS = 10
"""Most projected Jacobi sweeps of `slip_guess`."""
STEADY = 2
"""Sweeps in a row that leave the guessed set unchanged before `slip_guess` stops."""


def _pair_block(Ms: ScaledM, a: np.ndarray) -> np.ndarray:
    """M[a, a] (unscaled): a view of M when a is a range, else a gathered copy (`gather`)."""
    if a.size and a[-1] - a[0] + 1 == a.size:
        return Ms.M[a[0]:a[-1] + 1, a[0]:a[-1] + 1]
    return gather(Ms.M, a, a)


def slip_guess(Ms: ScaledM, qt: np.ndarray, twin: np.ndarray, tpart: slice,
               sweeps: int | None = None) -> np.ndarray | None:
    """Guessed active set (n,) bool of the twins' LCP (z~ outside tpart fixed; qt (n,) its
    q~, the first stage's w~ on tpart): for each pair, a_k when x_k > 0, b_k when x_k < 0,
    neither when x_k = 0, after up to `sweeps` projected Jacobi sweeps from x = 0 (the first
    one gives the trial guess), stopping once the set stays the same for STEADY sweeps,
    or before a sweep whose step max |x_new - x| is not below the last one's (Jacobi need
    not converge: on a dense random compliance it turns back after a few sweeps; the set
    of the last contracting sweep is returned). None (use the trial guess) when a twin in
    tpart has no twin in it, a diagonal entry of H is not positive, or sweeps (default
    SWEEPS) is 0."""
    sweeps = SWEEPS if sweeps is None else sweeps
    if sweeps <= 0:
        return None
    pairs = _twin_pairs(twin, tpart)
    if pairs is None:
        return None
    a, b = pairs
    d = Ms.D[a]
    Ha = _pair_block(Ms, a)
    hd = d * d * np.diagonal(Ha) / Ms.mu
    if not (hd > 0).all():
        return None
    signs = _jacobi_signs(Ha, d, hd, Ms.mu, -qt[a] / hd, qt[b] / hd, sweeps)
    if signs is None:  # not finite from the first sweep
        return None
    pos, neg = signs
    Z = np.zeros(qt.size, dtype=bool)
    Z[a[pos]] = True
    Z[b[neg]] = True
    return Z


def _twin_pairs(twin: np.ndarray, tpart: slice) -> tuple[np.ndarray, np.ndarray] | None:
    """The pairs (a, b) (both (p,) int, a_k < b_k = twin a_k) of the twins in tpart; None
    when one of them has its twin outside tpart."""
    T = np.arange(tpart.start, tpart.stop)
    b = twin[T]
    if (b < tpart.start).any() or (b >= tpart.stop).any():
        return None
    a = T[b > T]
    return a, twin[a]


def _jacobi_signs(Ha: np.ndarray, d: np.ndarray, hd: np.ndarray, mu: float, ca: np.ndarray,
                  cb: np.ndarray, sweeps: int) -> tuple[np.ndarray, np.ndarray] | None:
    """(x > 0, x < 0) (p,) bool after up to `sweeps` projected Jacobi sweeps from x = 0 on
    the pairs' box problem (stopping rules of `slip_guess`); None when the first sweep is
    not finite. Ha: M[a, a] (unscaled), d: D[a], hd: the scaled diagonal of H, mu: the
    scaling's mu; ca = -q~_a / hd, cb = q~_b / hd."""
    # x_k = max(ca - t, 0) + min(cb - t, 0) with t = (H x)_k / H_kk - x_k; H x = d (M[a, a]
    # (d x)) / mu: a product with the unscaled block, no scaled copy of it
    g = d / (mu * hd)
    x = np.zeros(ca.size)
    pos = neg = None
    steady, last_step = 0, np.inf
    with np.errstate(all="ignore"):
        for k in range(sweeps):
            t = g * (Ha @ (d * x)) - x if k else x  # the first sweep: H x = 0
            xn = np.maximum(ca - t, 0.0) + np.minimum(cb - t, 0.0)
            step = float(np.abs(xn - x).max())
            if not step < last_step:  # growing (or not finite): Jacobi diverges here
                break
            x, last_step = xn, step
            p, m = x > 0, x < 0
            same = pos is not None and np.array_equal(p, pos) and np.array_equal(m, neg)
            steady = steady + 1 if same else 0
            pos, neg = p, m
            if steady >= STEADY:
                break
    return None if pos is None else (pos, neg)
