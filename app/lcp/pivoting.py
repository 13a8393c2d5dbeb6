"""Pivoting rules shared by both Lemke cores (tableau and revised): tolerances, the
lexicographic tie-break, the first pivot, and what a core returns (scaled units).

- Variables are numbered w_i -> i, z_i -> n + i, z0 -> 2 n. The basis system is
  ``I w - M z - d z0 = q`` with covering vector d.
- Anti-cycling: lexicographic ratio test. Ties in the minimum ratio are broken by comparing
  the rows of ``B^-1 B0`` (B0 = starting basis) scaled by the pivot column; when z0 is among
  the tied rows it leaves (the run ends with a solution).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_PIV_REL = 1e-11
"""Pivot-column entries below this fraction of the column's largest entry count as zero."""
_TIE_REL = 1e-11
"""A ratio ties the minimum when x_i - theta y_i <= this x max(1, max|x_B|) (scaled units)."""
_LEX_REL = 1e-9
"""Lexicographic comparisons: entries equal within this x the largest compared entry."""



@dataclass
class _CoreOut:
    """What a pivoting core returns (scaled units)."""

    status: str  # "solved" (candidate), "secondary ray", "pivot limit", "singular"
    zset: np.ndarray  # (n,) bool: z_i basic
    z: np.ndarray  # (n,) last iterate of z (0 where nonbasic)
    z0: float
    pivots: int
    refactorizations: int = 0


def _lexmin(V: np.ndarray) -> int:
    """Index of the lexicographically smallest row of V (k x m), with a relative tolerance."""
    tol = _LEX_REL * max(float(np.abs(V).max()), np.finfo(float).tiny)
    idx = np.arange(V.shape[0])
    while idx.size > 1:
        sub = V[idx]
        differ = (np.abs(sub - sub[0]) > tol).any(axis=0)
        cols = np.flatnonzero(differ)
        if cols.size == 0:  # rows equal within tolerance (cannot happen in exact arithmetic)
            return int(idx[0])
        col = sub[:, cols[0]]
        idx = idx[col <= col.min() + tol]
    return int(idx[0])


def _first_leaving(xb: np.ndarray, y: np.ndarray, pos: np.ndarray) -> int | None:
    """First pivot (z0 enters): the most infeasible row; ties -> largest start position.

    xb, y: basic values and z0 column (y < 0 on the rows of the start basis); pos: start
    position of each row's variable. Returns the row index or None if xb >= 0.
    """
    cand = np.flatnonzero((xb < 0) & (y < 0))
    if cand.size == 0:
        return None
    theta = xb[cand] / y[cand]
    tmax = theta.max()
    tie = cand[(tmax - theta) * (-y[cand]) <= _TIE_REL * max(1.0, float(np.abs(xb).max()))]
    return int(tie[np.argmax(pos[tie])])
