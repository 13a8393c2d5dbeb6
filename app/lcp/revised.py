"""Fast Lemke core: the revised method.

It keeps M and q and only an explicit inverse of the non-identity block of the basis
matrix (the columns of the basic z's and of the artificial z0), updated by rank-1 terms kept
in compact form (O(n k) work and memory traffic per pivot for k basic z's, no n x 2n
tableau), refactorised when a cheap residual test shows drift. Same pivoting rules as the
tableau core (`app.lcp.pivoting`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from app.lcp import pivoting as piv
from app.lcp.pivoting import _CoreOut, _first_leaving
from app.lcp.scaling import ScaledM as _ScaledM
from app.lcp.scaling import lu_or_none as _lu_or_none

_RES_REFACTOR = 1e-10
"""Revised method: refactorise when a solve's relative residual exceeds this."""
_ILL_GAP = 50
"""Revised method: pivots between refactorisations when even a fresh inverse misses the
residual threshold (ill-conditioned basis)."""
_REFINE_EVERY = 40
"""Revised method: refine the basic values by one residual correction every this many pivots."""
_COMPACT_TERMS = 32
"""Revised method: rank-1 updates kept in compact form before folding them into the inverse."""


class _Revised:
    """Basis of the revised method.

    The basis matrix has identity columns e_i for the basic w_i (rows W) and "non-identity"
    columns X = [-M[:, j] for basic z_j, -d if z0 is basic]. With R = the other rows
    (|R| = number of non-identity columns), B = [[I, X_W], [0, X_R]] after permutation and
    B^-1 = [[I, -X_W X_R^-1], [0, X_R^-1]], so only Xinv = X_R^-1 is kept.

    Storage is by slots: column slot c holds a non-identity variable (`slot_var`, its column
    in row c of `Xcols`), row slot p holds a row of R (`row_slot`); Xinv[c, p] is indexed
    (column slot, row slot). Free slots have zero rows/columns everywhere. The true inverse is
    ``Xinv[:h, :h] + Yu[:h, :t] @ Gv[:h, :t].T`` (rank-1 updates in compact form, folded
    into Xinv every `_COMPACT_TERMS` updates). Every basis change is a rank-1 update of the
    slot-space inverse (bordering, column or row replacement, deletion).
    """

    def __init__(self, M: _ScaledM, q: np.ndarray, d: np.ndarray, B0: np.ndarray):
        n = q.size
        self.n, self.M, self.d = n, M, d
        self.qpad = np.append(q, 0.0)
        self.start_z = np.flatnonzero(B0)
        self.cap = 0
        self.h = 0
        self.t = 0
        self.T = _COMPACT_TERMS
        self.Xinv = np.zeros((0, 0))
        self.Yu = np.zeros((0, self.T))
        self.Gv = np.zeros((0, self.T))
        self.Xcols = np.zeros((0, n + 1))
        self.slot_var = np.zeros(0, dtype=np.int64)
        self.row_slot = np.zeros(0, dtype=np.int64)
        self.xs = np.zeros(0)
        self.var_slot = np.full(n + 1, -1, dtype=np.int64)  # by variable id - n
        self.row_pos = np.full(n + 1, -1, dtype=np.int64)
        self.inW = np.ones(n, dtype=bool)
        self.xw = q.copy()
        self.free_c: list[int] = []
        self.free_r: list[int] = []
        self.refactorizations = 0
        self.since_refactor = 0
        self.xnorm = max(M.absmax, float(np.abs(d).max()), 1e-300)
        k = self.start_z.size
        if k:
            self._ensure_cap(k)
            self.h = k
            self.slot_var[:k] = n + self.start_z
            self.var_slot[self.start_z] = np.arange(k)
            self.row_slot[:k] = self.start_z
            self.row_pos[self.start_z] = np.arange(k)
            self.inW[self.start_z] = False
            self.Xcols[:k, :n] = -M.cols(self.start_z).T
            self.xw[self.start_z] = 0.0

    # ---- storage -------------------------------------------------------------------
    def _ensure_cap(self, need: int) -> None:
        if need <= self.cap:
            return
        n = self.n
        cap = min(max(need, 2 * self.cap, 64), max(n, 1))
        h = self.h
        Xinv = np.zeros((cap, cap))
        Xinv[:h, :h] = self.Xinv[:h, :h]
        Yu = np.zeros((cap, self.T))
        Yu[:h] = self.Yu[:h]
        Gv = np.zeros((cap, self.T))
        Gv[:h] = self.Gv[:h]
        Xcols = np.zeros((cap, n + 1))
        Xcols[:h] = self.Xcols[:h]
        slot_var = np.full(cap, -1, dtype=np.int64)
        slot_var[:h] = self.slot_var[:h]
        row_slot = np.full(cap, n, dtype=np.int64)
        row_slot[:h] = self.row_slot[:h]
        xs = np.zeros(cap)
        xs[:h] = self.xs[:h]
        self.Xinv, self.Yu, self.Gv, self.Xcols = Xinv, Yu, Gv, Xcols
        self.slot_var, self.row_slot, self.xs, self.cap = slot_var, row_slot, xs, cap

    def _new_slots(self) -> tuple[int, int]:
        """A free (column slot, row slot) pair; the high-water mark grows if none is free."""
        if self.free_c:
            return self.free_c.pop(), self.free_r.pop()
        h = self.h
        self._ensure_cap(h + 1)
        self.Xinv[h, : h + 1] = 0.0
        self.Xinv[: h + 1, h] = 0.0
        self.Yu[h] = 0.0
        self.Gv[h] = 0.0
        self.h = h + 1
        return h, h

    def column(self, var: int) -> np.ndarray:
        """Basis-system column (n + 1,) of a z_j or z0 (last entry 0 for free slots)."""
        n = self.n
        a = np.empty(n + 1)
        a[:n] = -self.M.col(var - n) if var < 2 * n else -self.d
        a[n] = 0.0
        return a

    # ---- products with the inverse -----------------------------------------------------
    def _inv_times(self, b: np.ndarray) -> np.ndarray:
        h, t = self.h, self.t
        y = self.Xinv[:h, :h] @ b
        if t:
            y += self.Yu[:h, :t] @ (self.Gv[:h, :t].T @ b)
        return y

    def _row_times_inv(self, x: np.ndarray) -> np.ndarray:
        h, t = self.h, self.t
        g = x @ self.Xinv[:h, :h]
        if t:
            g += (x @ self.Yu[:h, :t]) @ self.Gv[:h, :t].T
        return g

    def inv_row(self, c: int) -> np.ndarray:
        h, t = self.h, self.t
        r = self.Xinv[c, :h].copy()
        if t:
            r += self.Gv[:h, :t] @ self.Yu[c, :t]
        return r

    def inv_col(self, p: int) -> np.ndarray:
        h, t = self.h, self.t
        y = self.Xinv[:h, p].copy()
        if t:
            y += self.Yu[:h, :t] @ self.Gv[p, :t]
        return y

    def g_row(self, r: int) -> np.ndarray:
        """x_r X_R^-1 for a W row r (x_r = row r of X); -g is row r of B^-1 on R."""
        return self._row_times_inv(self.Xcols[: self.h, r])

    def add_rank1(self, u: np.ndarray, v: np.ndarray) -> None:
        """Xinv += u v^T (u, v of length h)."""
        h, t = self.h, self.t
        self.Yu[:h, t] = u
        self.Gv[:h, t] = v
        self.t = t + 1
        if self.t == self.T:
            self.fold()

    def fold(self) -> None:
        """Add the compact rank-1 terms into Xinv; clear the rows/columns of free slots."""
        h, t = self.h, self.t
        if t:
            self.Xinv[:h, :h] += self.Yu[:h, :t] @ self.Gv[:h, :t].T
            self.t = 0
        if self.free_c:
            self.Xinv[self.free_c, :h] = 0.0
            self.Xinv[:h, self.free_r] = 0.0

    def refactor(self) -> bool:
        """Compact the slots, invert X_R afresh, recompute the basic values. False if singular."""
        self.fold()
        n, h = self.n, self.h
        act = np.flatnonzero(self.slot_var[:h] >= 0)
        ract = np.flatnonzero(self.row_slot[:h] < n)
        k = act.size
        self.slot_var[:k] = self.slot_var[act]
        self.slot_var[k:h] = -1
        self.row_slot[:k] = self.row_slot[ract]
        self.row_slot[k:h] = n
        self.Xcols[:k] = self.Xcols[act]
        self.Xcols[k:h] = 0.0
        self.Xinv[:h, :h] = 0.0
        self.Yu[:h] = 0.0
        self.Gv[:h] = 0.0
        self.free_c, self.free_r = [], []
        self.xs[:h] = 0.0
        self.h = k
        self.var_slot[:] = -1
        self.var_slot[self.slot_var[:k] - n] = np.arange(k)
        self.row_pos[:] = -1
        self.row_pos[self.row_slot[:k]] = np.arange(k)
        self.refactorizations += 1
        self.since_refactor = 0
        if k:
            rows = self.row_slot[:k]
            XR = self.Xcols[:k, rows].T  # XR[p, c] = X[row_slot[p], slot c]
            lu = _lu_or_none(XR)
            if lu is None:
                return False
            self.Xinv[:k, :k] = sla.lu_solve(lu, np.eye(k), check_finite=False)
        self.recompute_values()
        return True

    def recompute_values(self) -> None:
        """Basic values x_B = B^-1 q from scratch (one extra residual correction)."""
        n, h = self.n, self.h
        rows = self.row_slot[:h]
        qR = self.qpad[rows]
        xs = self._inv_times(qR) if h else np.zeros(0)
        if h:
            xs += self._inv_times(qR - (xs @ self.Xcols[:h])[rows])
            Xx = xs @ self.Xcols[:h]
        else:
            Xx = np.zeros(n + 1)
        self.xs[:h] = xs
        self.xw = np.where(self.inW, self.qpad[:n] - Xx[:n], 0.0)

    def refine_values(self) -> None:
        """One residual correction of the basic values (drift control between refactors)."""
        h = self.h
        if not h:
            return
        rows = self.row_slot[:h]
        Xx = self.xs[:h] @ self.Xcols[:h]
        dx = self._inv_times(self.qpad[rows] - Xx[rows])
        self.xs[:h] += dx
        Xx += dx @ self.Xcols[:h]
        self.xw = np.where(self.inW, self.qpad[: self.n] - Xx[: self.n], 0.0)

    def ftran(self, var: int) -> tuple[np.ndarray, np.ndarray, float]:
        """B^-1 a for the column a of variable var: (y on column slots, y on rows W, resid).

        resid is the relative residual of X_R y_R = a_R, which comes for free from the
        n-vector X y_R that the W part needs anyway.
        """
        n, h = self.n, self.h
        rows = self.row_slot[:h]
        if var < n:  # w_var enters: a = e_var, var in R
            yR = self.inv_col(int(self.row_pos[var]))
            aR = (rows == var).astype(float)
            anorm = 1.0
        else:
            a = self.column(var)
            aR = a[rows]
            yR = self._inv_times(aR)
            anorm = float(np.abs(a).max())
        Xy = yR @ self.Xcols[:h] if h else np.zeros(n + 1)
        if var < n:
            yW = -Xy[:n]
            yW[var] += 1.0
        else:
            yW = a[:n] - Xy[:n]
        res = 0.0
        if h:
            scale = anorm + self.xnorm * float(np.abs(yR).max())
            res = float(np.abs(Xy[rows] - aR).max()) / max(scale, 1e-300)
        return yR, yW, res

    # ---- state queries -------------------------------------------------------------------
    def z_values(self) -> tuple[np.ndarray, np.ndarray, float]:
        n, h = self.n, self.h
        sv = self.slot_var[:h]
        zmask = (sv >= n) & (sv < 2 * n)
        z = np.zeros(n)
        z[sv[zmask] - n] = self.xs[:h][zmask]
        zset = np.zeros(n, dtype=bool)
        zset[sv[zmask] - n] = True
        c0 = self.var_slot[n]
        return z, zset, float(self.xs[c0]) if c0 >= 0 else 0.0

    def lex_rows(self, kinds: list[tuple[str, int]]) -> np.ndarray:
        """Rows of B^-1 B0 (B0 = start basis) for the given basic variables.

        kinds: ("w", row i) or ("s", column slot c). Returns (len(kinds), n).
        """
        n, h = self.n, self.h
        rows = self.row_slot[:h]
        out = np.zeros((len(kinds), n + 1))
        for k, (kind, i) in enumerate(kinds):
            if kind == "w":
                out[k, i] = 1.0
                out[k, rows] = -self.g_row(i)
            else:
                out[k, rows] = self.inv_row(i)
        out = out[:, :n]
        if self.start_z.size:
            out[:, self.start_z] = -(out @ self.M.cols(self.start_z))
        return out


def _core_revised(
    M: _ScaledM, q: np.ndarray, d: np.ndarray, B0: np.ndarray, max_pivots: int
) -> _CoreOut:
    """Revised Lemke (same pivoting rules as `_core_tableau`, see `_Revised`)."""
    n = q.size
    S = _Revised(M, q, d, B0)
    z0var = 2 * n
    if B0.any() and not S.refactor():
        return _CoreOut("singular", B0.copy(), np.zeros(n), 0.0, 0, S.refactorizations)
    # first pivot: z0 enters, the most infeasible basic variable leaves
    r, yR, yW = _first_pivot_row(S)
    if r is None:
        return _revised_out(S, "solved", 0)
    if max_pivots < 1:
        return _revised_out(S, "pivot limit", 0)
    leaving = _pivot(S, z0var, r, yR, yW)
    pivots = 1
    refactor_gap = 1
    while True:
        e = leaving + n if leaving < n else leaving - n
        if pivots >= max_pivots:
            return _revised_out(S, "pivot limit", pivots)
        if S.since_refactor and S.since_refactor % _REFINE_EVERY == 0:
            S.refine_values()
        yR, yW, res = S.ftran(e)
        if res > _RES_REFACTOR and S.since_refactor >= refactor_gap:
            if not S.refactor():
                return _revised_out(S, "singular", pivots)
            yR, yW, res = S.ftran(e)
            # still above the threshold on a fresh inverse: ill-conditioned basis, where
            # refactorising at every pivot would not help; wait a while before the next one
            refactor_gap = _ILL_GAP if res > _RES_REFACTOR else 1
        r = _leaving_row(S, yR, yW)
        if r is None:
            return _revised_out(S, "secondary ray", pivots)
        leaving = _pivot(S, e, r, yR, yW)
        pivots += 1
        if leaving == z0var:
            return _revised_out(S, "solved", pivots)


def _revised_out(S: _Revised, status: str, pivots: int) -> _CoreOut:
    """What the revised core returns on the current basis of S."""
    z, zset, z0 = S.z_values()
    return _CoreOut(status, zset, z, z0, pivots, S.refactorizations)


def _first_pivot_row(S: _Revised) -> tuple[int | None, np.ndarray, np.ndarray]:
    """The first pivot (z0 enters): the leaving position (as for `_pivot`: a row r < n of
    W, else n + column slot; None when the start basis is feasible) and z0's column
    (on the column slots, on the rows W)."""
    n, h = S.n, S.h
    yR, yW, _ = S.ftran(2 * n)
    xb = np.concatenate([np.where(S.inW, S.xw, 0.0), S.xs[:h]])
    yb = np.concatenate([np.where(S.inW, yW, 0.0), yR])
    pos = np.concatenate([np.arange(n), S.slot_var[:h] - n])
    return _first_leaving(xb, yb, pos), yR, yW


def _leaving_row(S: _Revised, yR: np.ndarray, yW: np.ndarray) -> int | None:
    """Ratio test for the entering column (yR on the column slots, yW on the rows W): the
    leaving position as for `_pivot` (z0 when it ties, else the lexicographic minimum of
    the tied rows of B^-1 B0 / y), None when no entry is positive (secondary ray)."""
    n, h = S.n, S.h
    inW = S.inW
    active = S.slot_var[:h] >= 0
    ymax = max(
        float(np.abs(yW[inW]).max()) if inW.any() else 0.0,
        float(np.abs(yR[active]).max()) if active.any() else 0.0,
    )
    ptol = piv._PIV_REL * ymax
    cw = np.flatnonzero(inW & (yW > ptol))
    cs = np.flatnonzero(active & (yR > ptol))
    if cw.size + cs.size == 0:
        return None
    xw, xs = S.xw, S.xs[:h]
    rw = np.maximum(xw[cw], 0.0) / yW[cw]
    rs = np.maximum(xs[cs], 0.0) / yR[cs]
    theta = min(rw.min() if rw.size else np.inf, rs.min() if rs.size else np.inf)
    xmax = max(1.0, float(np.abs(xw).max()) if n else 0.0, float(np.abs(xs).max(initial=0)))
    ttol = piv._TIE_REL * xmax
    tw = cw[(rw - theta) * yW[cw] <= ttol]
    ts = cs[(rs - theta) * yR[cs] <= ttol]
    c0 = S.var_slot[n]
    if c0 >= 0 and c0 in ts:
        return n + int(c0)
    if tw.size + ts.size == 1:
        return int(tw[0]) if tw.size else n + int(ts[0])
    kinds = [("w", int(i)) for i in tw] + [("s", int(c)) for c in ts]
    ys = np.concatenate([yW[tw], yR[ts]])
    k = piv._lexmin(S.lex_rows(kinds) / ys[:, None])
    return int(tw[k]) if k < tw.size else n + int(ts[k - tw.size])


def _pivot(S: _Revised, e: int, r: int, yR: np.ndarray, yW: np.ndarray) -> int:
    """Exchange: variable e enters, the basic variable at r leaves (r < n: w_r of row r;
    r >= n: column slot r - n). Updates the values and the inverse; returns the leaving id."""
    n = S.n
    h = S.h
    leave_w = r < n
    if leave_w:
        piv = yW[r]
        theta = max(S.xw[r] / piv, 0.0)
        leaving = r
    else:
        c = r - n
        piv = yR[c]
        theta = max(S.xs[c] / piv, 0.0)
        leaving = int(S.slot_var[c])
    # values: x_B -= theta y, the entering variable takes theta
    S.xw -= theta * yW
    S.xs[:h] -= theta * yR
    if e >= n:  # a z_j or z0 enters
        if leave_w:
            _border(S, e, r, yR, piv, theta)
        else:
            _replace_column(S, e, c, leaving, yR, piv, theta)
    else:  # w_e enters (row e in R, row slot p)
        p = int(S.row_pos[e])
        if leave_w:
            _replace_row(S, p, r, yR, piv)
        else:
            _delete_slots(S, c, p, leaving, yR, piv)
        S.row_pos[e] = -1
        S.inW[e] = True
        S.xw[e] = theta
    S.since_refactor += 1
    return leaving


def _border(S: _Revised, e: int, r: int, yR: np.ndarray, piv: float, theta: float) -> None:
    """z_e (or z0) enters, w_r leaves: bordering, with a new column slot and row slot."""
    n, h = S.n, S.h
    a = S.column(e)
    g = S.g_row(r)
    cn, pn = S._new_slots()
    h2 = S.h
    u = np.zeros(h2)
    u[:h] = yR
    u[cn] = -1.0
    v = np.zeros(h2)
    v[:h] = g
    v[pn] = -1.0
    S.add_rank1(u, v / piv)
    S.Xcols[cn] = a
    S.slot_var[cn] = e
    S.var_slot[e - n] = cn
    S.row_slot[pn] = r
    S.row_pos[r] = pn
    S.inW[r] = False
    S.xw[r] = 0.0
    S.xs[cn] = theta


def _replace_column(S: _Revised, e: int, c: int, leaving: int, yR: np.ndarray, piv: float,
                    theta: float) -> None:
    """z_e (or z0) enters in column slot c, whose z (or z0) `leaving` leaves."""
    n = S.n
    a = S.column(e)
    rowc = S.inv_row(c)
    u = yR.copy()
    u[c] -= 1.0
    S.add_rank1(-u, rowc / piv)
    S.var_slot[leaving - n] = -1
    S.Xcols[c] = a
    S.slot_var[c] = e
    S.var_slot[e - n] = c
    S.xs[c] = theta


def _replace_row(S: _Revised, p: int, r: int, yR: np.ndarray, piv: float) -> None:
    """A w enters from row slot p, w_r leaves: row slot p now holds row r."""
    g = S.g_row(r)
    g[p] -= 1.0
    S.add_rank1(yR, g / piv)
    S.row_slot[p] = r
    S.row_pos[r] = p
    S.inW[r] = False
    S.xw[r] = 0.0


def _delete_slots(S: _Revised, c: int, p: int, leaving: int, yR: np.ndarray,
                  piv: float) -> None:
    """A w enters from row slot p, the z (or z0) `leaving` of column slot c leaves: both
    slots are freed."""
    n = S.n
    rowc = S.inv_row(c)
    S.add_rank1(-yR, rowc / piv)  # zeroes row c and column p (up to rounding)
    S.Xcols[c] = 0.0
    S.var_slot[leaving - n] = -1
    S.slot_var[c] = -1
    S.row_slot[p] = n
    S.xs[c] = 0.0
    S.free_c.append(c)
    S.free_r.append(p)
