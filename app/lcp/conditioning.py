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
