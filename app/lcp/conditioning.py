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


def alike_groups(k: np.ndarray, among: np.ndarray) -> np.ndarray:
    """(n,) int: a group label per unknown of k (n, n) among `among` (n,) bool whose row and
    column of k agree with another's to NULL_SHARE of k's largest entry (two pairs with
    the same constraint rows: a duplicated pair), -1 for the others. Their force's split
    is not unique, only its sum. Found by sorting a random projection of the rows, then
    checked row by row."""
    n = k.shape[0]
    label = np.full(n, -1)
    idx = np.flatnonzero(among)
    if idx.size < 2:
        return label
    tol = NULL_SHARE * max(float(np.abs(k).max()), 1e-300)
    key = k[idx] @ np.random.default_rng(0).standard_normal(n)
    order = np.argsort(key, kind="stable")
    new_run = np.r_[True, np.diff(key[order]) > tol * n]  # runs of near-equal projections
    head = idx[order][np.maximum.accumulate(np.where(new_run, np.arange(idx.size), 0))]
    member = idx[order]
    same = ((np.abs(k[member] - k[head]).max(axis=1) <= tol)
            & (np.abs(k[:, member] - k[:, head]).max(axis=0) <= tol))
    count = np.bincount(head[same], minlength=n)
    keep = same & (count[head] > 1)
    label[member[keep]] = head[keep]
    return label


def determined_accuracy(k: np.ndarray, free: np.ndarray) -> float:
    """`relative_accuracy` of k (n, n) for the unknowns that k determines, free (n,) bool
    the unknowns that need not be unique (a floating body's mode amplitude that no closed
    pair holds: it slides on slipping pairs). When k's numerical null space (singular
    values at most n eps x the largest, as numpy's matrix_rank) lies in the free unknowns
    and in the splits between alike unknowns (`alike_groups`: on each group its entries
    sum to 0, only the group's sum is determined), the others are unique and their
    accuracy is that of k + U0 V0^T (U0, V0 the left and right null vectors: a unit tie on
    the null directions, the rest of k unchanged). Else, or when no null space explains
    it, `relative_accuracy` of k itself (1.0 for a singular k). Without free unknowns or
    alike ones no null space can be explained: no SVD (at n = 1500, 6 s beside the LU's
    0.3 s: reviewer `review11`)."""
    accuracy = relative_accuracy(k)
    if accuracy <= SVD_FROM or not np.isfinite(k).all():
        return accuracy
    group = alike_groups(k, ~free)[~free]
    if not free.any() and (group < 0).all():
        return accuracy
    u, s, vt = np.linalg.svd(k)
    null = s <= s[0] * k.shape[0] * EPS
    if not null.any():
        return accuracy
    v = vt[null][:, ~free]  # (null, bound) the null vectors on the unknowns to be unique
    heads = np.unique(group[group >= 0])
    sums = np.stack([v[:, group == h].sum(axis=1) for h in heads], axis=1) if heads.size \
        else np.zeros((v.shape[0], 0))
    if max(np.abs(v[:, group < 0]).max(initial=0.0),
           np.abs(sums).max(initial=0.0)) > NULL_SHARE:
        return accuracy
    return relative_accuracy(k + u[:, null] @ vt[null])
