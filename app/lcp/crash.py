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
    frees the rows R and fixes x_R = 0): one small dense solve, plus one solve with the
    base LU per changed index, kept while that index stays changed.
    """

    def __init__(self, Ms: ScaledM, qs: np.ndarray):
        self.Ms, self.qs = Ms, qs
        self.base = np.zeros(0, dtype=np.int64)
        self.lu = None
        self.factorizations = 0
        self.ycache: dict[int, np.ndarray] = {}
        self.schur = None

    def factor(self, Z: np.ndarray) -> bool:
        self.base = Z.copy()
        self.lu = lu_or_none(self.Ms.sub(Z)) if Z.size else None
        self.factorizations += 1
        self.ycache = {}
        return Z.size == 0 or self.lu is not None

    def _columns(self, A: np.ndarray, R: np.ndarray) -> np.ndarray:
        """A0^-1 [M~[Z0, A], E_R] (k0, |A| + |R|), from the cache where possible."""
        b0 = self.base
        keys = np.concatenate([A, R])
        miss = [k for k in range(keys.size) if int(keys[k]) not in self.ycache]
        if miss:
            miss = np.asarray(miss)
            U = np.zeros((b0.size, miss.size))
            am = miss[miss < A.size]
            if am.size:
                U[:, : am.size] = self.Ms.cols(A[am])[b0]
            rm = miss[miss >= A.size] - A.size
            if rm.size:
                U[np.searchsorted(b0, R[rm]), am.size + np.arange(rm.size)] = 1.0
            Y = sla.lu_solve(self.lu, U, check_finite=False)
            for c, key in enumerate(np.concatenate([A[am], R[rm]])):
                self.ycache[int(key)] = Y[:, c]
        return np.stack([self.ycache[int(k)] for k in keys], axis=1)

    def solve(self, zset: np.ndarray, rhs: np.ndarray | None = None,
              refactor: bool = True) -> np.ndarray | None:
        """x (n,) with M~_ZZ x_Z = rhs_Z (default -q~), 0 elsewhere; None when singular.
        refactor=False reuses the factors of the previous call (same set)."""
        n = self.qs.size
        b = -self.qs if rhs is None else rhs
        Z = np.flatnonzero(zset)
        inbase = np.zeros(n, dtype=bool)
        inbase[self.base] = True
        A = Z[~inbase[Z]]
        R = self.base[~zset[self.base]]
        k0 = self.base.size
        if refactor and (A.size + R.size > _REFACTOR_FRACTION * max(k0, 1) or self.lu is None):
            if not self.factor(Z):
                return None
            A = R = np.zeros(0, dtype=np.int64)
        z = np.zeros(n)
        if Z.size == 0:
            return z
        b0 = self.base
        x0 = sla.lu_solve(self.lu, b[b0], check_finite=False)
        if A.size + R.size:
            if refactor or self.schur is None:
                Y = self._columns(A, R)
                pos = np.searchsorted(b0, R)
                V = np.zeros((A.size + R.size, k0))
                if A.size:
                    V[: A.size] = self.Ms.rows(A)[:, b0]
                V[A.size + np.arange(R.size), pos] = 1.0
                C = np.zeros((A.size + R.size,) * 2)
                if A.size:
                    C[: A.size, : A.size] = self.Ms.sub(A)
                lu_s = lu_or_none(C - V @ Y)
                if lu_s is None:
                    return None
                self.schur = (Y, V, lu_s)
            Y, V, lu_s = self.schur
            rhs2 = np.concatenate([b[A], np.zeros(R.size)]) - V @ x0
            t = sla.lu_solve(lu_s, rhs2, check_finite=False)
            x0 = x0 - Y @ t
            z[A] = t[: A.size]
        else:
            self.schur = None
        z[b0] = x0
        z[R] = 0.0
        return z if np.isfinite(z).all() else None


def crash_basis(Ms: ScaledM, qs: np.ndarray, twin: np.ndarray | None = None,
                max_iterations: int = MAX_ITERATIONS
                ) -> tuple[np.ndarray, int, np.ndarray | None]:
    """Guessed active set (n,) bool by block principal pivoting, the iterations used, and
    z~ on that set (one residual correction applied) when the iteration converged.

    Starts from Z = {i : q~_i < 0, i not a twin} (for contact: every pair sticks). Returns
    the set with the fewest infeasible indices met (the exact answer's set when the
    iteration converged).
    """
    n = qs.size
    twin = find_twins(Ms) if twin is None else twin
    Z = (qs < 0) & (twin < 0)
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
