"""An independent reference for small LCPs: every solution by enumeration of the 2^n
complementary index sets, and feasibility by linear programming. Plain numpy/scipy; used
by the adversarial checker (`app.lcp.audit`, scripts/check_lcp.py) and tests, never by
`lemke`.

For integer data the enumeration is exact (rational elimination with `fractions`); else
each set Z is solved in floating point (least squares, so a singular M_ZZ with a solution
is seen too) and kept when its residual and signs pass a tolerance relative to the data.
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
from scipy.optimize import linprog

MAX_ENUMERATE = 12
"""Largest n that `solutions` enumerates (2^12 = 4096 sets)."""


def _rational_solve(A: list[list[Fraction]], b: list[Fraction]) -> list[Fraction] | None:
    """The solution x of A x = b (square, exact), or None when A is singular."""
    k = len(b)
    T = [row[:] + [b[i]] for i, row in enumerate(A)]
    for c in range(k):
        p = next((r for r in range(c, k) if T[r][c] != 0), None)
        if p is None:
            return None
        T[c], T[p] = T[p], T[c]
        for r in range(k):
            if r != c and T[r][c] != 0:
                f = T[r][c] / T[c][c]
                T[r] = [a - f * bb for a, bb in zip(T[r], T[c], strict=True)]
    return [T[i][k] / T[i][i] for i in range(k)]


def _is_integer(a: np.ndarray) -> bool:
    return bool(np.all(a == np.round(a)) and np.abs(a).max(initial=0.0) < 2**31)


def solutions(M: np.ndarray, q: np.ndarray, tol: float = 1e-9) -> list[np.ndarray]:
    """All solutions z (n,) of LCP(M, q) found on the complementary sets (one per set:
    for a singular M_ZZ the least-squares one). n <= MAX_ENUMERATE. Exact for integer
    M and q; else relative tolerance tol on z, w and the residual of M_ZZ z_Z = -q_Z."""
    M = np.asarray(M, dtype=float)
    q = np.asarray(q, dtype=float)
    n = q.size
    if n > MAX_ENUMERATE:
        raise ValueError(f"enumeration is for n <= {MAX_ENUMERATE}, got {n}")
    exact = _is_integer(M) and _is_integer(q)
    if exact:
        Mf = [[Fraction(int(v)) for v in row] for row in M]
        qf = [Fraction(int(v)) for v in q]
    out = []
    for mask in itertools.product([False, True], repeat=n):
        Z = np.flatnonzero(mask)
        if exact:
            z = _exact_on(Mf, qf, Z, n)
        else:
            z = _float_on(M, q, Z, tol)
        if z is not None:
            out.append(z)
    return out


def _exact_on(Mf, qf, Z: np.ndarray, n: int) -> np.ndarray | None:
    """The exact solution on set Z if M_ZZ is regular and z >= 0, w >= 0; else None."""
    zr = [Fraction(0)] * n
    if Z.size:
        x = _rational_solve([[Mf[i][j] for j in Z] for i in Z], [-qf[i] for i in Z])
        if x is None:
            return None
        for i, v in zip(Z, x, strict=True):
            zr[i] = v
    if any(v < 0 for v in zr):
        return None
    for i in range(n):
        if sum(Mf[i][j] * zr[j] for j in range(n)) + qf[i] < 0:
            return None
    return np.array([float(v) for v in zr])


def _float_on(M: np.ndarray, q: np.ndarray, Z: np.ndarray, tol: float) -> np.ndarray | None:
    """The (least-squares) solution on Z when it passes the checks at tol; else None."""
    n = q.size
    z = np.zeros(n)
    if Z.size:
        A = M[np.ix_(Z, Z)]
        x = np.linalg.lstsq(A, -q[Z], rcond=None)[0]
        scale = np.abs(q[Z]) + np.abs(A) @ np.abs(x)
        if (np.abs(A @ x + q[Z]) > tol * np.maximum(scale, 1e-300)).any():
            return None
        z[Z] = x
    rows = np.abs(q) + np.abs(M) @ np.abs(z)
    w = M @ z + q
    zs = np.abs(z).max(initial=0.0)
    if (z < -tol * max(zs, 1e-300)).any() or (w < -tol * np.maximum(rows, 1e-300)).any():
        return None
    return np.maximum(z, 0.0)


def feasible(M: np.ndarray, q: np.ndarray) -> bool:
    """Whether {z >= 0, M z + q >= 0} is non-empty (HiGHS LP; for a copositive-plus M,
    e.g. positive semidefinite, the LCP then has a solution)."""
    n = q.size
    if (q >= 0).all():
        return True
    s = np.abs(M).max(axis=1) + np.abs(q)
    s[s == 0] = 1.0
    res = linprog(np.zeros(n), A_ub=-M / s[:, None], b_ub=q / s, bounds=[(0, None)] * n,
                  method="highs")
    return res.status == 0


def is_p_matrix(M: np.ndarray) -> bool:
    """Every principal minor positive (n <= MAX_ENUMERATE; floating determinants)."""
    n = M.shape[0]
    for mask in itertools.product([False, True], repeat=n):
        Z = np.flatnonzero(mask)
        if Z.size and np.linalg.det(M[np.ix_(Z, Z)]) <= 0:
            return False
    return True


def is_psd(M: np.ndarray, rel: float = 1e-12) -> bool:
    """Whether the symmetric part of M is positive semidefinite to rel x its norm."""
    S = 0.5 * (M + M.T)
    lam = np.linalg.eigvalsh(S) if S.size else np.zeros(0)
    return bool(lam.min(initial=0.0) >= -rel * max(np.abs(lam).max(initial=0.0), 1e-300))
