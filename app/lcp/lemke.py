"""Lemke's complementary pivoting method for the linear complementarity problem (LCP).

LCP(M, q): given M (n x n, any matrix, not necessarily symmetric) and q (n,), find
z (n,) with

    z >= 0,   w = M z + q >= 0,   z_i w_i = 0 for every i.

`lemke` is the public solver. It runs a *revised* Lemke method: it keeps M and q and only
an explicit inverse of the non-identity block of the basis matrix (the columns of the basic
z's and of the artificial z0), updated by rank-1 terms kept in compact form (O(n k) work and
memory traffic per pivot for k basic z's, no n x 2n tableau), refactorised when a cheap
residual test shows drift. `_lemke_tableau` is the textbook full-tableau version, kept as a
slow, simple reference for the tests. Both share the same pivoting rules, so on the same
data they visit the same bases.

Conventions shared by both:

- Variables are numbered w_i -> i, z_i -> n + i, z0 -> 2 n. The basis system is
  ``I w - M z - d z0 = q`` with covering vector d (all ones after scaling for a cold start).
- Anti-cycling: lexicographic ratio test. Ties in the minimum ratio are broken by comparing
  the rows of ``B^-1 B0`` (B0 = starting basis) scaled by the pivot column; when z0 is among
  the tied rows it leaves (the run ends with a solution).
- The problem is first scaled symmetrically, ``M~ = D M D / mu``, ``q~ = D q / nu`` with D a
  positive diagonal of powers of two (Jacobi scaling, or the row/column maximum where the
  diagonal is too small), so pivot and tie tolerances are unit free (contact LCPs mix gap
  and force units). The LCP is invariant under this: z = (nu / mu) D z~, w = nu D^-1 w~.
- A run that ends with a candidate basis is never returned unchecked: z on the final basis is
  recomputed by a fresh dense solve (LU plus one refinement step), tiny negative entries
  are set to 0, w = M z + q is recomputed in the caller's units and checked (see `lemke`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from app.lcp.crash import crash_basis
from app.lcp.scaling import RCOND_MIN as _RCOND_MIN  # noqa: F401 (tests read it here)
from app.lcp.scaling import ScaledM as _ScaledM
from app.lcp.scaling import absmax as _absmax  # noqa: F401
from app.lcp.scaling import lu_or_none as _lu_or_none
from app.lcp.scaling import row_blocks as _row_blocks
from app.lcp.scaling import scaling as _scaling

__all__ = ["LCPResult", "lemke", "default_max_pivots", "STATUSES"]

STATUSES = ("solved", "secondary ray", "pivot limit", "inaccurate")
"""Possible `LCPResult.status` values ("inaccurate": a candidate failed the final check)."""

DEFAULT_TOL = 1e-9
"""Default relative tolerance of the final check (see `lemke`)."""

_PIV_REL = 1e-11
"""Pivot-column entries below this fraction of the column's largest entry count as zero."""
_TIE_REL = 1e-11
"""A ratio ties the minimum when x_i - theta y_i <= this x max(1, max|x_B|) (scaled units)."""
_LEX_REL = 1e-9
"""Lexicographic comparisons: entries equal within this x the largest compared entry."""
_RES_REFACTOR = 1e-10
"""Revised method: refactorise when a solve's relative residual exceeds this."""
_ILL_GAP = 50
"""Revised method: pivots between refactorisations when even a fresh inverse misses the
residual threshold (ill-conditioned basis)."""
_REFINE_EVERY = 40
"""Revised method: refine the basic values by one residual correction every this many pivots."""
_COMPACT_TERMS = 32
"""Revised method: rank-1 updates kept in compact form before folding them into the inverse."""


def default_max_pivots(n: int) -> int:
    """Default pivot budget for an LCP of size n: 50 n + 100 + 2^min(n, 20).

    Contact LCPs need about n pivots; the 2^n term lets small LCPs with exponentially long
    Lemke paths (Murty's triangular examples: 2^n pivots) finish.
    """
    return 50 * n + 100 + 2 ** min(n, 20)


@dataclass
class LCPResult:
    """Outcome of `lemke`.

    z, w: (n,) arrays with w = M z + q (for "solved" a checked solution; otherwise the last
    iterate, z >= 0 but not a solution). pivots: number of basis exchanges (all runs,
    including a failed warm start). status: one of `STATUSES`. complementarity: max_i
    |z_i w_i| of the returned pair. basis: (n,) bool, True where z_i is basic at the end;
    pass it as ``basis=`` to a later call with the same M. message: human readable summary.
    warm_start: what happened to a given ``basis`` ("none", "accepted", "lemke", "cold").
    """

    z: np.ndarray
    w: np.ndarray
    pivots: int
    status: str
    complementarity: float
    basis: np.ndarray
    message: str
    warm_start: str = "none"
    refactorizations: int = field(default=0)
    residual: float = 0.0
    """Largest relative violation of the final check (see `lemke`, tol); 0 for q >= 0."""

    @property
    def ok(self) -> bool:
        """True when status == "solved" (z passed the final check)."""
        return self.status == "solved"


# --------------------------------------------------------------------------------------
# shared pieces
# --------------------------------------------------------------------------------------


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


# --------------------------------------------------------------------------------------
# reference: full tableau
# --------------------------------------------------------------------------------------


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
        ptol = _PIV_REL * float(np.abs(y).max())
        cand = np.flatnonzero(y > ptol)
        if cand.size == 0:
            return out("secondary ray", pivots)
        ratio = np.maximum(x[cand], 0.0) / y[cand]
        theta = ratio.min()
        tie = cand[(ratio - theta) * y[cand] <= _TIE_REL * max(1.0, float(np.abs(x).max()))]
        if np.any(basic[tie] == z0col):
            r = int(tie[basic[tie] == z0col][0])
        elif tie.size == 1:
            r = int(tie[0])
        else:
            V = T[np.ix_(tie, start)] / y[tie, None]
            r = int(tie[_lexmin(V)])
        leaving = int(basic[r])
        pivot(r, e)
        pivots += 1
        if leaving == z0col:
            return out("solved", pivots)


# --------------------------------------------------------------------------------------
# fast: revised method
# --------------------------------------------------------------------------------------


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

    def out(status: str, pivots: int) -> _CoreOut:
        z, zset, z0 = S.z_values()
        return _CoreOut(status, zset, z, z0, pivots, S.refactorizations)

    if B0.any() and not S.refactor():
        return _CoreOut("singular", B0.copy(), np.zeros(n), 0.0, 0, S.refactorizations)

    # first pivot: z0 enters, the most infeasible basic variable leaves
    yR, yW, _ = S.ftran(z0var)
    h = S.h
    xb = np.concatenate([np.where(S.inW, S.xw, 0.0), S.xs[:h]])
    yb = np.concatenate([np.where(S.inW, yW, 0.0), yR])
    pos = np.concatenate([np.arange(n), S.slot_var[:h] - n])
    r = _first_leaving(xb, yb, pos)
    if r is None:
        return out("solved", 0)
    if max_pivots < 1:
        return out("pivot limit", 0)
    leaving = _pivot(S, z0var, r, yR, yW)
    pivots = 1
    refactor_gap = 1
    while True:
        e = leaving + n if leaving < n else leaving - n
        if pivots >= max_pivots:
            return out("pivot limit", pivots)
        if S.since_refactor and S.since_refactor % _REFINE_EVERY == 0:
            S.refine_values()
        yR, yW, res = S.ftran(e)
        if res > _RES_REFACTOR and S.since_refactor >= refactor_gap:
            if not S.refactor():
                return out("singular", pivots)
            yR, yW, res = S.ftran(e)
            # still above the threshold on a fresh inverse: ill-conditioned basis, where
            # refactorising at every pivot would not help; wait a while before the next one
            refactor_gap = _ILL_GAP if res > _RES_REFACTOR else 1
        h = S.h
        inW = S.inW
        active = S.slot_var[:h] >= 0
        ymax = max(
            float(np.abs(yW[inW]).max()) if inW.any() else 0.0,
            float(np.abs(yR[active]).max()) if active.any() else 0.0,
        )
        ptol = _PIV_REL * ymax
        cw = np.flatnonzero(inW & (yW > ptol))
        cs = np.flatnonzero(active & (yR > ptol))
        if cw.size + cs.size == 0:
            return out("secondary ray", pivots)
        xw, xs = S.xw, S.xs[:h]
        rw = np.maximum(xw[cw], 0.0) / yW[cw]
        rs = np.maximum(xs[cs], 0.0) / yR[cs]
        theta = min(rw.min() if rw.size else np.inf, rs.min() if rs.size else np.inf)
        xmax = max(1.0, float(np.abs(xw).max()) if n else 0.0, float(np.abs(xs).max(initial=0)))
        ttol = _TIE_REL * xmax
        tw = cw[(rw - theta) * yW[cw] <= ttol]
        ts = cs[(rs - theta) * yR[cs] <= ttol]
        c0 = S.var_slot[n]
        if c0 >= 0 and c0 in ts:
            r = n + int(c0)
        elif tw.size + ts.size == 1:
            r = int(tw[0]) if tw.size else n + int(ts[0])
        else:
            kinds = [("w", int(i)) for i in tw] + [("s", int(c)) for c in ts]
            ys = np.concatenate([yW[tw], yR[ts]])
            k = _lexmin(S.lex_rows(kinds) / ys[:, None])
            r = int(tw[k]) if k < tw.size else n + int(ts[k - tw.size])
        leaving = _pivot(S, e, r, yR, yW)
        pivots += 1
        if leaving == z0var:
            return out("solved", pivots)


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
        a = S.column(e)
        if leave_w:  # bordering: new column slot and row slot
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
        else:  # column replacement in slot c
            rowc = S.inv_row(c)
            u = yR.copy()
            u[c] -= 1.0
            S.add_rank1(-u, rowc / piv)
            S.var_slot[leaving - n] = -1
            S.Xcols[c] = a
            S.slot_var[c] = e
            S.var_slot[e - n] = c
            S.xs[c] = theta
    else:  # w_e enters (row e in R, row slot p)
        p = int(S.row_pos[e])
        if leave_w:  # row replacement: row slot p now holds row r
            g = S.g_row(r)
            g[p] -= 1.0
            S.add_rank1(yR, g / piv)
            S.row_slot[p] = r
            S.row_pos[r] = p
            S.inW[r] = False
            S.xw[r] = 0.0
        else:  # deletion of column slot c and row slot p
            rowc = S.inv_row(c)
            S.add_rank1(-yR, rowc / piv)  # zeroes row c and column p (up to rounding)
            S.Xcols[c] = 0.0
            S.var_slot[leaving - n] = -1
            S.slot_var[c] = -1
            S.row_slot[p] = n
            S.xs[c] = 0.0
            S.free_c.append(c)
            S.free_r.append(p)
        S.row_pos[e] = -1
        S.inW[e] = True
        S.xw[e] = theta
    S.since_refactor += 1
    return leaving


# --------------------------------------------------------------------------------------
# driver: scaling, warm start, final solve and check
# --------------------------------------------------------------------------------------


def _validate(M, q) -> tuple[np.ndarray, np.ndarray]:
    M = np.asarray(M, dtype=float)
    q = np.asarray(q, dtype=float).reshape(-1)
    n = q.size
    if M.shape != (n, n):
        raise ValueError(f"M must be ({n}, {n}) to match q of length {n}, got {M.shape}")
    if n and not (np.isfinite(M.max()) and np.isfinite(M.min()) and np.isfinite(q).all()):
        raise ValueError("M and q must be finite")
    return M, q


def _check(M: np.ndarray, q: np.ndarray, z: np.ndarray, tol: float):
    """w = M z + q and whether (z, w) passes the final check; returns (w, ok, comp, worst)."""
    w = M @ z + q
    s = np.abs(q)
    row_max = np.zeros(q.size)
    for i0, i1 in _row_blocks(q.size):
        a = np.abs(M[i0:i1])
        row_max[i0:i1] = a.max(axis=1) if a.size else 0.0
        if z.any():
            s[i0:i1] += a @ z
    # Floor for rows whose terms all cancel at round-off level (e.g. q_i = -1e-17 where the
    # rest of q is O(1)): 1e-4 x the row's largest coefficient x the problem's z scale.
    m_max = row_max.max(initial=0.0)
    z_scale = max(float(z.max(initial=0.0)),
                  float(np.abs(q).max(initial=0.0)) / m_max if m_max > 0 else 0.0)
    s = np.maximum(s, 1e-4 * row_max * z_scale)
    neg = np.maximum(-w, 0.0)
    comp_res = np.where(z > 0, np.abs(w), 0.0)
    viol = np.maximum(neg, comp_res)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(viol > 0, viol / s, 0.0)
    worst = float(rel.max()) if rel.size else 0.0
    ok = bool((z >= 0).all() and worst <= tol)
    comp = float(np.abs(z * w).max()) if z.size else 0.0
    return w, ok, comp, worst


def _solve_on(Ms: _ScaledM, qs: np.ndarray, zset: np.ndarray) -> np.ndarray | None:
    """z~ with z~_Z = -M~_ZZ^-1 q~_Z (LU + one refinement), 0 elsewhere; None if singular."""
    n = qs.size
    Z = np.flatnonzero(zset)
    zt = np.zeros(n)
    if Z.size == 0:
        return zt
    A = Ms.sub(Z)
    lu = _lu_or_none(A)
    if lu is None:
        return None
    x = sla.lu_solve(lu, -qs[Z], check_finite=False)
    x -= sla.lu_solve(lu, A @ x + qs[Z], check_finite=False)
    if not np.isfinite(x).all():
        return None
    zt[Z] = x
    return zt


class _Problem:
    """Caller data, scaled copy and the final solve + check."""

    def __init__(self, M: np.ndarray, q: np.ndarray, tol: float):
        self.M, self.q, self.tol = M, q, tol
        self.Ms, self.D, self.mu, self.nu = _scaling(M, q)
        D = self.D
        self.qs = D * q / self.nu
        self.zfac = self.D * (self.nu / self.mu)  # z = zfac * z~

    def finish(self, zt: np.ndarray | None):
        """Unscale, clip, check. Returns (z, w, ok, comp, worst) or None if zt is None."""
        if zt is None:
            return None
        z = np.maximum(zt * self.zfac, 0.0)
        w, ok, comp, worst = _check(self.M, self.q, z, self.tol)
        return z, w, ok, comp, worst

    def candidate(self, core: _CoreOut):
        """Best checked answer from a core that reported a candidate basis."""
        first = self.finish(_solve_on(self.Ms, self.qs, core.zset))
        if first is not None and first[2]:
            return first
        second = self.finish(core.z)
        if second[2] or first is None:
            return second
        return first if first[4] <= second[4] else second


def _try_basis(P: _Problem, B0: np.ndarray, zt: np.ndarray | None = None):
    """The checked answer on the complementary basis B0 (z_B = -M_BB^-1 q_B, one LU and one
    refinement step), or None when B0 is singular or its answer fails the check. This is
    exactly what a Lemke run from B0 that needs no pivot returns. zt: z~ on B0 already
    computed (e.g. by the crash, with one refinement step), tried first."""
    if zt is not None:
        out = P.finish(zt)
        if out[2]:
            return out
    out = P.finish(_solve_on(P.Ms, P.qs, B0))
    return out if out is not None and out[2] else None


def _run(
    core,
    M,
    q,
    max_pivots: int | None,
    tol: float | None,
    basis,
    cold_start: bool = True,
    crash: bool = True,
) -> LCPResult:
    M, q = _validate(M, q)
    n = q.size
    tol = DEFAULT_TOL if tol is None else float(tol)
    max_pivots = default_max_pivots(n) if max_pivots is None else int(max_pivots)
    zero = np.zeros(n)
    if (q >= 0).all():
        return LCPResult(
            zero, q.copy(), 0, "solved", 0.0, np.zeros(n, dtype=bool), "q >= 0: z = 0 solves it"
        )
    P = _Problem(M, q, tol)
    pivots = 0
    refacts = 0
    warm = "none"
    note = ""
    given = basis is not None
    zt = None
    if given:
        B0 = np.asarray(basis, dtype=bool).reshape(-1)
        if B0.shape != (n,):
            raise ValueError(f"basis must have shape ({n},), got {B0.shape}")
    elif crash:
        B0, iters, zt = crash_basis(P.Ms, P.qs)
        note = f"crash basis ({iters} block pivoting iterations); "
    if (given or crash) and B0.any():
        how = "accepted" if given else "crash"
        sol = _try_basis(P, B0, zt)
        if sol is not None:
            z, w, ok, comp, worst = sol
            msg = ("the warm-start basis solves it" if given
                   else f"{note}the crash basis solves it")
            return LCPResult(z, w, 0, "solved", comp, B0.copy(), msg, how, 0, worst)
        # covering vector B0 @ 1: Lemke on the LCP transformed by the pivot on B0
        d = -P.Ms.matvec(B0.astype(float))
        d[~B0] += 1.0
        res = core(P.Ms, P.qs, d, B0, max_pivots)
        pivots += res.pivots
        refacts += res.refactorizations
        if res.status == "solved":
            z, w, ok, comp, worst = P.candidate(res)
            if ok:
                msg = (f"{note}solved from the {'warm-start' if given else 'crash'} basis "
                       f"in {pivots} pivots")
                return LCPResult(z, w, pivots, "solved", comp, res.zset.copy(), msg,
                                 "lemke" if given else "crash+lemke", refacts, worst)
        warm = "cold"
        note += (f"{'warm start' if given else 'the run from the crash basis'} ended with "
                 f"'{res.status}' after {res.pivots} pivots; ")
        if given and not cold_start:
            z = np.maximum(res.z * P.zfac, 0.0)
            w, _, comp, worst = _check(M, q, z, tol)
            return LCPResult(z, w, pivots, "warm start failed", comp, res.zset.copy(),
                             note + "no cold start (cold_start=False)", "failed",
                             refacts, worst)
    res = core(P.Ms, P.qs, np.ones(n), np.zeros(n, dtype=bool), max(max_pivots - pivots, 0))
    pivots += res.pivots
    refacts += res.refactorizations
    if res.status == "solved":
        z, w, ok, comp, worst = P.candidate(res)
        if ok:
            msg = f"{note}solved in {pivots} pivots"
            return LCPResult(z, w, pivots, "solved", comp, res.zset.copy(), msg, warm, refacts,
                             worst)
        msg = (
            f"{note}Lemke ended on a complementary basis after {pivots} pivots but the "
            f"solution fails the check (worst relative violation {worst:.3g} > tol {tol:.3g})"
        )
        return LCPResult(z, w, pivots, "inaccurate", comp, res.zset.copy(), msg, warm, refacts,
                         worst)
    z = np.maximum(res.z * P.zfac, 0.0)
    w, _, comp, worst = _check(M, q, z, tol)
    if res.status == "secondary ray":
        status = "secondary ray"
        msg = (
            f"{note}secondary ray after {pivots} pivots: no solution was found from this start "
            "(the artificial variable z0 could not be driven to 0); for contact this means no "
            "static equilibrium"
        )
    elif res.status == "singular":
        status = "inaccurate"
        msg = f"{note}the basis became numerically singular after {pivots} pivots"
    else:
        status = "pivot limit"
        msg = f"{note}pivot limit ({max_pivots}) reached; z, w are the last iterate"
    return LCPResult(z, w, pivots, status, comp, res.zset.copy(), msg, warm, refacts, worst)


def lemke(
    M: np.ndarray,
    q: np.ndarray,
    *,
    max_pivots: int | None = None,
    tol: float | None = None,
    basis: np.ndarray | None = None,
    cold_start: bool = True,
    crash: bool = True,
) -> LCPResult:
    """Solve LCP(M, q): z >= 0, w = M z + q >= 0, z.w = 0, by Lemke's method.

    M: (n, n) float array (need not be symmetric); q: (n,).
    max_pivots: pivot budget, default `default_max_pivots(n)` (50 n + 100 + 2^min(n, 20));
        when it is used up the status is "pivot limit" and z, w are the last iterate.
    tol: relative tolerance of the final check, default 1e-9. With the row sizes
        s_i = |q_i| + sum_j |M_ij| z_j (the size of the terms that make w_i), a returned
        "solved" pair satisfies z >= 0 exactly, w_i >= -tol s_i, and |w_i| <= tol s_i
        wherever z_i > 0 (so |z_i w_i| <= tol z_i s_i). The check is per row, so it is
        independent of the units of each row (e.g. gaps and forces in one LCP).
    basis: optional (n,) bool warm start, True where z_i is guessed basic (for example
        `LCPResult.basis` of a previous call with the same M and a nearby q). If the
        complementary basis it names is feasible (z_B = -M_BB^-1 q_B >= 0, w >= 0, checked)
        the answer comes back with 0 pivots. Otherwise Lemke runs from that basis (the
        principal pivot transform of the LCP on B, covering vector 1 in transformed
        variables); if that fails (singular M_BB, secondary ray, pivot limit) a cold start
        follows. Pivots of all runs are counted.
    crash: without a basis, guess one by block principal pivoting (`app.lcp.crash`) and
        start from it as from a warm start (warm_start "crash" when the guess solves it,
        "crash+lemke" when Lemke finished from it, "cold" when that failed and a cold start
        followed). False: the textbook cold start (covering vector 1).
    cold_start: with a basis, False returns at once when the warm start fails (status
        "warm start failed", warm_start "failed") instead of starting cold, so that a
        caller can try another basis first.

    Returns an `LCPResult`. "solved" only after the check above passes (z on the final
    basis is recomputed by a fresh LU solve); "secondary ray": no solution was found from
    this start (for a copositive-plus M, e.g. positive semidefinite, there is none; for
    contact: no static equilibrium); "inaccurate": a candidate failed the check.
    q >= 0 returns z = 0 with 0 pivots.
    """
    return _run(_core_revised, M, q, max_pivots, tol, basis, cold_start, crash)


def _lemke_tableau(
    M: np.ndarray,
    q: np.ndarray,
    *,
    max_pivots: int | None = None,
    tol: float | None = None,
    basis: np.ndarray | None = None,
    cold_start: bool = True,
    crash: bool = True,
) -> LCPResult:
    """Reference: `lemke` with the full-tableau core (O(n^2) per pivot; for tests)."""
    return _run(_core_tableau, M, q, max_pivots, tol, basis, cold_start, crash)
