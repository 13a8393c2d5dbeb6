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
    M = Ms.dense()
    idx = np.arange(n)
    T = np.hstack([np.eye(n), -M, -d[:, None], q[:, None]])
    basic = np.where(B0, n + idx, idx)  # variable basic in each tableau row
    start = basic.copy()  # lexicographic columns: the start basis, by position
    if B0.any():
        lu = _lu_or_none(T[:, basic])
        if lu is None:
            return _CoreOut("singular", B0.copy(), np.zeros(n), 0.0, 0)
        T = sla.lu_solve(lu, T, check_finite=False)
    z0col, qcol = 2 * n, 2 * n + 1

    def out(status: str, pivots: int) -> _CoreOut:
        z = np.zeros(n)
        zb = (basic >= n) & (basic < 2 * n)
        z[basic[zb] - n] = T[zb, qcol]
        z0 = T[basic == z0col, qcol]
        zset = np.zeros(n, dtype=bool)
        zset[basic[zb] - n] = True
        return _CoreOut(status, zset, z, float(z0[0]) if z0.size else 0.0, pivots)

    def pivot(r: int, e: int) -> None:
        T[r] /= T[r, e]
        col = T[:, e].copy()
        col[r] = 0.0
        T[:] -= np.outer(col, T[r])
        basic[r] = e

    r = _first_leaving(T[:, qcol], T[:, z0col], idx)  # row i holds start position i
    if r is None:
        return out("solved", 0)
    if max_pivots < 1:
        return out("pivot limit", 0)
    leaving = int(basic[r])
    pivot(r, z0col)
    pivots = 1
    while True:
        e = leaving + n if leaving < n else leaving - n  # complement of the leaving variable
        if pivots >= max_pivots:
            return out("pivot limit", pivots)
        y = T[:, e]
        x = T[:, qcol]
        ptol = piv._PIV_REL * float(np.abs(y).max())
        cand = np.flatnonzero(y > ptol)
        if cand.size == 0:
            return out("secondary ray", pivots)
        ratio = np.maximum(x[cand], 0.0) / y[cand]
        theta = ratio.min()
        tie = cand[(ratio - theta) * y[cand] <= piv._TIE_REL * max(1.0, float(np.abs(x).max()))]
        if np.any(basic[tie] == z0col):
            r = int(tie[basic[tie] == z0col][0])
        elif tie.size == 1:
            r = int(tie[0])
        else:
            V = T[np.ix_(tie, start)] / y[tie, None]
            r = int(tie[piv._lexmin(V)])
        leaving = int(basic[r])
        pivot(r, e)
        pivots += 1
        if leaving == z0col:
            return out("solved", pivots)
