"""The accuracy round-off allows a dense linear system's answer: eps x its condition number.

A solve in double precision of K x = b returns x to about eps x cond(K) relative to |x|
(the data of K itself carry round-off of that size: C is formed by solves of the stiffness).
cond(K) is estimated in the 1-norm by LAPACK's dgecon on the LU of dgetrf: one O(n^3 / 3)
factorisation and O(n^2) per estimate, no SVD (Higham, "Accuracy and Stability of Numerical
Algorithms", ch. 15: the estimate is within a small factor of the true 1-norm value).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import lapack

EPS = float(np.finfo(float).eps)


def condition_estimate(k: np.ndarray) -> float:
    """The 1-norm condition number estimate of the square matrix k (n, n): |k|_1 x an
    estimate of |k^-1|_1 (LAPACK dgetrf then dgecon). inf when k is singular (an exact
    zero pivot or a reciprocal estimate of 0) or not finite; 1.0 for n = 0."""
    n = k.shape[0]
    if n == 0:
        return 1.0
    if not np.isfinite(k).all():
        return float("inf")
    anorm = float(np.abs(k).sum(axis=0).max())
    lu, _, info = lapack.dgetrf(k)
    if info != 0 or anorm == 0.0:  # info > 0: an exact zero pivot
        return float("inf")
    rcond, info = lapack.dgecon(lu, anorm, norm="1")
    if info != 0 or not rcond > 0.0:
        return float("inf")
    return 1.0 / float(rcond)


def relative_accuracy(k: np.ndarray) -> float:
    """eps x `condition_estimate` of k: the relative accuracy (of the largest entry of the
    answer) that round-off in k and in its solve allow, at most 1.0 (no digit assured;
    also when k is singular: a finite number for summary.json, whose inf is not JSON)."""
    return min(EPS * condition_estimate(k), 1.0)


SVD_FROM = 1e-6
"""A `relative_accuracy` above which `determined_accuracy` asks the SVD whether k is
singular only in unknowns that need not be unique (50 x every shipped scene's figure,
1.9e-8 at most, README `lcp_accuracy`, and 100 x below the warning's 1e-4: the SVD, some
times the LU's cost, runs only where the step would warn)."""

NULL_SHARE = 1e-8
"""Largest share of a null vector (unit 2-norm) on the unknowns that must be unique for
the null space to count as lying in the free ones (multibody.toml --sd 1 --mesh-size 1.2:
4.3e-14)."""


def determined_accuracy(k: np.ndarray, free: np.ndarray) -> float:
    """`relative_accuracy` of k (n, n) for the unknowns that k determines, free (n,) bool
    the unknowns that need not be unique (a floating body's mode amplitude that no closed
    pair holds: it slides on slipping pairs). When k's numerical null space (singular
    values at most n eps x the largest, as numpy's matrix_rank) lies in the free unknowns,
    the others are unique and their accuracy is that of k + U0 V0^T (U0, V0 the left and
    right null vectors: a unit tie on the null directions, the rest of k unchanged). Else,
    or when no null space explains it, `relative_accuracy` of k itself."""
    accuracy = relative_accuracy(k)
    if accuracy <= SVD_FROM or not free.any() or not np.isfinite(k).all():
        return accuracy
    u, s, vt = np.linalg.svd(k)
    null = s <= s[0] * k.shape[0] * EPS
    if not null.any() or np.abs(vt[null][:, ~free]).max(initial=0.0) > NULL_SHARE:
        return accuracy
    return relative_accuracy(k + u[:, null] @ vt[null])
