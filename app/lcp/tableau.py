"""Reference Lemke core: the textbook full tableau (O(n^2) per pivot; for tests).

It follows the same pivoting rules as the revised core (`app.lcp.pivoting`), so on the same
data both visit the same bases.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from app.lcp import pivoting as piv
from app.lcp.pivoting import _CoreOut, _first_leaving
from app.lcp.scaling import ScaledM as _ScaledM
from app.lcp.scaling import lu_or_none as _lu_or_none


def _core_tableau(
    Ms: _ScaledM, q: np.ndarray, d: np.ndarray, B0: np.ndarray, max_pivots: int
) -> _CoreOut:
    """Textbook Lemke on the full tableau T = B^-1 [I, -M, -d, q] (n x (2n + 2))."""
    n = q.size
    tab = _start_tableau(Ms, q, d, B0)
    if tab is None:
        return _CoreOut("singular", B0.copy(), np.zeros(n), 0.0, 0)
    T, basic = tab
    z0col, qcol = 2 * n, 2 * n + 1
    r = _first_leaving(T[:, qcol], T[:, z0col], np.arange(n))  # row i holds start position i
    if r is None:
        return _tableau_out(T, basic, "solved", 0)
    if max_pivots < 1:
        return _tableau_out(T, basic, "pivot limit", 0)
    start = basic.copy()  # lexicographic columns: the start basis, by position
    leaving = int(basic[r])
    _tableau_pivot(T, basic, r, z0col)
    pivots = 1
    while True:
        e = leaving + n if leaving < n else leaving - n  # complement of the leaving variable
        if pivots >= max_pivots:
            return _tableau_out(T, basic, "pivot limit", pivots)
        r = _tableau_leaving_row(T, basic, start, e)
        if r is None:
            return _tableau_out(T, basic, "secondary ray", pivots)
        leaving = int(basic[r])
        _tableau_pivot(T, basic, r, e)
        pivots += 1
        if leaving == z0col:
            return _tableau_out(T, basic, "solved", pivots)


def _start_tableau(Ms: _ScaledM, q: np.ndarray, d: np.ndarray, B0: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray] | None:
    """The tableau (n, 2n + 2) on the start basis B0 and the variable basic in each row
    (z_i in the rows of B0, else w_i); None when that basis is singular."""
    n = q.size
    idx = np.arange(n)
    T = np.hstack([np.eye(n), -Ms.dense(), -d[:, None], q[:, None]])
    basic = np.where(B0, n + idx, idx)  # variable basic in each tableau row
    if B0.any():
        lu = _lu_or_none(T[:, basic])
        if lu is None:
            return None
        T = sla.lu_solve(lu, T, check_finite=False)
    return T, basic


def _tableau_out(T: np.ndarray, basic: np.ndarray, status: str, pivots: int) -> _CoreOut:
    """What the tableau core returns: z (and z0) read from the q column of T."""
    n = T.shape[0]
    qcol = 2 * n + 1
    z = np.zeros(n)
    zb = (basic >= n) & (basic < 2 * n)
    z[basic[zb] - n] = T[zb, qcol]
    z0 = T[basic == 2 * n, qcol]
    zset = np.zeros(n, dtype=bool)
    zset[basic[zb] - n] = True
    return _CoreOut(status, zset, z, float(z0[0]) if z0.size else 0.0, pivots)


def _tableau_pivot(T: np.ndarray, basic: np.ndarray, r: int, e: int) -> None:
    """Pivot T in place on row r, column e (variable e becomes basic in row r)."""
    T[r] /= T[r, e]
    col = T[:, e].copy()
    col[r] = 0.0
    T[:] -= np.outer(col, T[r])
    basic[r] = e


def _tableau_leaving_row(T: np.ndarray, basic: np.ndarray, start: np.ndarray,
                         e: int) -> int | None:
    """Ratio test for the entering column e: the leaving row (z0's when it ties, else the
    lexicographic minimum over the columns `start` of the start basis), None when the
    column has no positive entry (secondary ray)."""
    n = T.shape[0]
    y = T[:, e]
    x = T[:, 2 * n + 1]
    ptol = piv._PIV_REL * float(np.abs(y).max())
    cand = np.flatnonzero(y > ptol)
    if cand.size == 0:
        return None
    ratio = np.maximum(x[cand], 0.0) / y[cand]
    theta = ratio.min()
    tie = cand[(ratio - theta) * y[cand] <= piv._TIE_REL * max(1.0, float(np.abs(x).max()))]
    if np.any(basic[tie] == 2 * n):
        return int(tie[basic[tie] == 2 * n][0])
    if tie.size == 1:
        return int(tie[0])
    V = T[np.ix_(tie, start)] / y[tie, None]
    return int(tie[piv._lexmin(V)])
