"""Crash basis for Lemke: a cheap guess of the active set, handed to Lemke as a warm start.

A cold Lemke run adds about one basic variable per pivot, so an LCP whose answer has k
positive z's costs at least k pivots of O(n k) each. A crash guesses the answer's active
set Z (z_i > 0) by block principal pivoting (Kostreva; Judice and Pires): solve
``M_ZZ z_Z = -q_Z``, then move every infeasible index at once (z_i < 0 leaves Z, w_i < 0
joins Z), and repeat. Each iteration is one solve with the current block; after the first
LU the changed indices are handled by a bordered Schur complement on the LU of the base
block (a few triangular solves per changed index), and the base is refactorised only
when many indices changed. Columns that are exact negatives of each other ("twins", e.g.
the forward and backward slips of one contact pair) never enter together (that block
would be singular).

The crash is only a guess: `lemke` checks the answer on the guessed basis and, when it is
not a solution, runs Lemke from it. Everything here works on the scaled LCP (`_ScaledM`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

from app.lcp.scaling import ScaledM, lu_or_none

MAX_ITERATIONS = 30
"""Block pivoting iterations before the best set so far is handed to Lemke."""
_REFACTOR_FRACTION = 0.3
"""Refactorise the base block when more than this fraction of it changed."""
_FEAS_REL = 1e-12
"""z_i or w_i counts as negative below -this x max(1, max |z|) (scaled units)."""


def find_twins(Ms: ScaledM) -> np.ndarray:
    """(n,) index of the column that is the negative of column i, or -1.

    Found from two products R^T M~ with random R (negated columns have negated sums); a
    false match would only keep two indices apart in the guess, never change an answer.
    """
    n = Ms.n
    twin = np.full(n, -1, dtype=np.int64)
    if n < 2:
        return twin
    r = np.random.default_rng(20261123).standard_normal((2, n))
    s = ((r * Ms.D) @ Ms.M) * Ms.D  # (2, n); the 1/mu factor does not matter here
    order = np.argsort(np.abs(s[0]), kind="stable")
    sa, sb = s[0, order], s[1, order]
    tol = 1e-12 * (np.abs(sa[1:]) + np.abs(sb[1:]))
    close = (np.abs(sa[1:] + sa[:-1]) <= tol) & (np.abs(sb[1:] + sb[:-1]) <= tol)
    close &= (sa[1:] != 0.0) & (np.sign(sa[1:]) != np.sign(sa[:-1]))
    for k in np.flatnonzero(close):
        i, j = int(order[k]), int(order[k + 1])
        if twin[i] < 0 and twin[j] < 0:
            twin[i], twin[j] = j, i
    return twin


class _BlockSolver:
    """Solves M~[Z, Z] x = b for a changing set Z.

    With the LU of a base block A0 = M~[Z0, Z0], a set Z = Z0 - R + A is solved through the
    bordered system [[A0, M~[Z0, A], E_R], [M~[A, Z0], M~[A, A], 0], [E_R^T, 0, 0]] (E_R
    frees the rows R and fixes x_R = 0): its Schur complement S = C - V A0^-1 U on the
    changed indices, then one small dense solve. Every index changed since the last
    factorization keeps its column A0^-1 u, row v and entries of S, so an iteration costs
    base-LU solves only for the indices that changed for the first time.
    """

    def __init__(self, Ms: ScaledM, qs: np.ndarray):
        self.Ms, self.qs = Ms, qs
        self.base = np.zeros(0, dtype=np.int64)
        self.lu = None
        self.factorizations = 0
        self._reset()

    def _reset(self) -> None:
        k0 = self.base.size
        self.keys = np.zeros(0, dtype=np.int64)  # changed indices seen since the factor
        self.key_pos = {}
        self.YT = np.zeros((0, k0))  # rows: (A0^-1 u_key)^T
        self.V = np.zeros((0, k0))
        self.S = np.zeros((0, 0))
        self.last = None  # (sel, LU of S[sel, sel]) of the last solve

    def factor(self, Z: np.ndarray) -> bool:
        self.base = Z.copy()
        self.lu = lu_or_none(self.Ms.sub(Z)) if Z.size else None
        self.factorizations += 1
        self._reset()
        return Z.size == 0 or self.lu is not None

    def _add_keys(self, new: np.ndarray) -> None:
        """Columns, rows and Schur entries of indices changed for the first time."""
        b0 = self.base
        inbase = np.isin(new, b0)
        added = new[~inbase]
        U = np.zeros((b0.size, new.size))
        V = np.zeros((new.size, b0.size))
        if added.size:
            U[:, ~inbase] = self.Ms.cols(added)[b0]
            V[~inbase] = self.Ms.rows(added)[:, b0]
        pos = np.searchsorted(b0, new[inbase])  # base is sorted
        U[pos, np.flatnonzero(inbase)] = 1.0
        V[np.flatnonzero(inbase), pos] = 1.0
        YT = sla.lu_solve(self.lu, U, check_finite=False).T
        old_added = ~np.isin(self.keys, b0)
        c_nn = np.zeros((new.size, new.size))
        if added.size:
            c_nn[np.ix_(~inbase, ~inbase)] = self.Ms.sub(added)
        c_no = np.zeros((new.size, self.keys.size))
        c_on = np.zeros((self.keys.size, new.size))
        if added.size and old_added.any():
            oa = self.keys[old_added]
            c_no[np.ix_(~inbase, old_added)] = self.Ms.rows(added)[:, oa]
            c_on[np.ix_(old_added, ~inbase)] = self.Ms.cols(added)[oa]
        K = self.keys.size
        S = np.empty((K + new.size, K + new.size))
        S[:K, :K] = self.S
        S[:K, K:] = c_on - self.V @ YT.T
        S[K:, :K] = c_no - V @ self.YT.T
        S[K:, K:] = c_nn - V @ YT.T
        self.S = S
        self.YT = np.vstack([self.YT, YT])
        self.V = np.vstack([self.V, V])
        for i, key in enumerate(new):
            self.key_pos[int(key)] = K + i
        self.keys = np.concatenate([self.keys, new])

    def solve(self, zset: np.ndarray, rhs: np.ndarray | None = None,
              refactor: bool = True) -> np.ndarray | None:
        """x (n,) with M~_ZZ x_Z = rhs_Z (default -q~), 0 elsewhere; None when singular.
        refactor=False: the same set as the previous call (its factors are reused)."""
        n = self.qs.size
        b = -self.qs if rhs is None else rhs
        Z = np.flatnonzero(zset)
        inbase = np.zeros(n, dtype=bool)
        inbase[self.base] = True
        A = Z[~inbase[Z]]
        R = self.base[~zset[self.base]]
        k0 = self.base.size
        changed = np.concatenate([A, R])
        if refactor and (changed.size > _REFACTOR_FRACTION * max(k0, 1) or self.lu is None):
            if not self.factor(Z):
                return None
            changed = np.zeros(0, dtype=np.int64)
        z = np.zeros(n)
        if Z.size == 0:
            return z
        b0 = self.base
        x0 = sla.lu_solve(self.lu, b[b0], check_finite=False)
        if changed.size:
            if refactor or self.last is None:
                new = np.array([k for k in changed if int(k) not in self.key_pos],
                               dtype=np.int64)
                if new.size:
                    self._add_keys(new)
                sel = np.array([self.key_pos[int(k)] for k in changed], dtype=np.int64)
                lu_s = lu_or_none(self.S[np.ix_(sel, sel)])
                if lu_s is None:
                    return None
                self.last = (sel, lu_s)
            sel, lu_s = self.last
            rhs2 = np.concatenate([b[A], np.zeros(R.size)]) - self.V[sel] @ x0
            t = sla.lu_solve(lu_s, rhs2, check_finite=False)
            x0 = x0 - self.YT[sel].T @ t
            z[A] = t[: A.size]
        z[b0] = x0
        z[R] = 0.0
        return z if np.isfinite(z).all() else None


def crash_basis(Ms: ScaledM, qs: np.ndarray, twin: np.ndarray | None = None,
                max_iterations: int = MAX_ITERATIONS, start: np.ndarray | None = None
                ) -> tuple[np.ndarray, int, np.ndarray | None]:
    """Guessed active set (n,) bool by block principal pivoting, the iterations used, and
    z~ on that set (one residual correction applied) when the iteration converged.

    Starts from Z = {i : q~_i < 0, i not a twin} (for contact: every pair sticks). Returns
    the set with the fewest infeasible indices met (the exact answer's set when the
    iteration converged). start: another first set (e.g. a warm-start basis).
    """
    n = qs.size
    twin = find_twins(Ms) if twin is None else twin
    Z = (qs < 0) & (twin < 0) if start is None else _untwin(start.copy(), start, qs, twin)
    solver = _BlockSolver(Ms, qs)
    best, best_bad = Z.copy(), n + 1
    for it in range(1, max_iterations + 1):
        z = solver.solve(Z)
        if z is None:
            return best, it, None
        w = Ms.matvec(z) + qs
        tol = _FEAS_REL * max(1.0, float(np.abs(z).max()))
        bad_z = Z & (z < -tol)
        bad_w = ~Z & (w < -tol)
        nbad = int(bad_z.sum() + bad_w.sum())
        if nbad < best_bad:
            best, best_bad = Z.copy(), nbad
        if nbad == 0:
            dz = solver.solve(Z, rhs=np.where(Z, -w, 0.0), refactor=False)
            return Z, it, (z + dz if dz is not None else z)
        Z = _untwin((Z & ~bad_z) | bad_w, Z, w, twin)
    return best, max_iterations, None


def _untwin(Znew: np.ndarray, Zold: np.ndarray, w: np.ndarray, twin: np.ndarray) -> np.ndarray:
    """Drop one of each twin pair in Znew: the one that was in Zold (its twin asks to enter),
    else the one with the larger w."""
    i = np.flatnonzero(Znew & (twin >= 0))
    j = twin[i]
    both = Znew[j] & (i < j)
    i, j = i[both], j[both]
    drop_i = np.where(Zold[i], True, np.where(Zold[j], False, w[i] > w[j]))
    out = Znew.copy()
    out[i[drop_i]] = False
    out[j[~drop_i]] = False
    return out
