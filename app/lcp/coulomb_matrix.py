"""The block matrix of the modified Coulomb LCP (METHOD.md section 5) from a compliance:
plain numpy, shared by the interface stage (app/interface/coulomb.py) and by the LCP test
cases of tests and benchmarks (app/lcp/cases.py).

Per pair (m pairs, the frictional subset F of size mf, r floating-body modes):
z = (p + a, s+, s-, alpha+, alpha-), and with H = C_tt^-1, A = C_nn - C_nt H C_tn,
Bm = C_nt H, V = N - Bm T, W = H T, Z = T^T H T and D = mu on the frictional rows

    M = [[ A,        Bm,   -Bm,    V,    -V  ],
         [ D - Bm^T,  H,    -H,   -W,     W  ],
         [ D + Bm^T, -H,     H,    W,    -W  ],
         [-V^T,      -W^T,   W^T,  Z,    -Z  ],
         [ V^T,       W^T,  -W^T, -Z,     Z  ]]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from app.errors import SolveError

DEPENDENT_REL = 1e-10
"""Tangential compliance eigenvalues below this x the largest span its null space."""

NULL_STIFFNESS_REL = 1e9
"""Stiffness on that null space, relative to the largest stiffness 1 / lambda_min kept."""


@dataclass
class CoulombMatrix:
    """M (n, n) and the blocks the solution recovery needs: edges of the five block rows,
    H (mf, mf), Bm (m, mf), V (m, r), W (mf, r), Z (r, r), the frictional pairs `fric`,
    N (m, r), T (mf, r) of the frictional pairs, and the number of dependent tangential
    directions (see `tangential_stiffness`)."""

    M: np.ndarray
    edges: list[int]
    h: np.ndarray
    bm: np.ndarray
    v: np.ndarray
    w: np.ndarray
    z: np.ndarray
    fric: np.ndarray
    nm: np.ndarray
    tm: np.ndarray
    dependent: int


def tangential_stiffness(ctt: np.ndarray) -> tuple[np.ndarray, int]:
    """(H, n_dependent): H = C_tt^-1, (mf, mf), and the number of dependent directions.

    C_tt is singular when tangential rows of G are dependent on the free DOFs: a pair
    whose tangential motion is fixed by supports (a zero row), or two pairs whose slave
    tangential DOFs are fixed and which project onto the same master point (equal rows).
    The tangential forces along such a direction v do not move anything: they are not
    unique. There H = V diag(1/lambda) V^T + k0 N0 N0^T, with k0 = NULL_STIFFNESS_REL x
    the largest kept 1/lambda: a stiff tie on the null space N0, so the LCP stays regular
    and picks one of the equivalent force splits, while the displacements, which come
    from C, are exact.
    """
    try:
        fac = cho_factor(ctt)
        h = cho_solve(fac, np.eye(ctt.shape[0]))
        h = 0.5 * (h + h.T)
        ok = bool(np.all(np.isfinite(h)))
        if ok:
            lam_max = float(np.abs(np.diag(ctt)).max())
            # Cholesky can pass a numerically singular C_tt: check the smallest pivot
            ok = float(np.diag(fac[0]).min() ** 2) > DEPENDENT_REL * lam_max
    except np.linalg.LinAlgError:
        ok = False
    if ok:
        return h, 0
    try:
        lam, vec = np.linalg.eigh(0.5 * (ctt + ctt.T))
    except np.linalg.LinAlgError:
        raise SolveError("the tangential contact compliance has no eigen-decomposition "
                         "(non-finite or badly scaled values): check the Young's moduli and "
                         "the loads") from None
    top = float(np.abs(lam).max(initial=0.0))
    if top == 0.0:
        raise SolveError("the tangential compliance of every frictional pair is zero: their "
                         "tangential motion is fixed by supports; set mu = 0 on the interface")
    keep = lam > DEPENDENT_REL * top
    vk, vn = vec[:, keep], vec[:, ~keep]
    k0 = NULL_STIFFNESS_REL / float(lam[keep].min())
    h = (vk / lam[keep]) @ vk.T + k0 * (vn @ vn.T)
    return 0.5 * (h + h.T), int((~keep).sum())


def coulomb_matrix(c: np.ndarray, mu: np.ndarray, frictional: np.ndarray,
                   n_modes: np.ndarray | None = None,
                   t_modes: np.ndarray | None = None) -> CoulombMatrix:
    """The LCP matrix for compliance c (2m, 2m; normal rows first, then tangential),
    friction coefficients mu (m,), frictional (m,) bool, and the floating modes' gap and
    slip per unit amplitude n_modes = G_n R (m, r), t_modes = G_t R (m, r)."""
    m = mu.size
    f = np.flatnonzero(frictional)
    mf = f.size
    cnn, cnt, ctt = c[:m, :m], c[:m, m:][:, f], c[m:, m:][np.ix_(f, f)]
    r = 0 if n_modes is None else n_modes.shape[1]
    nm = np.zeros((m, 0)) if n_modes is None else n_modes
    tm = np.zeros((mf, 0)) if t_modes is None else t_modes[f]
    h, dependent = tangential_stiffness(ctt) if mf else (np.zeros((0, 0)), 0)
    bm = cnt @ h  # (m, mf)
    a = cnn - bm @ cnt.T
    a = 0.5 * (a + a.T)
    d = np.zeros((mf, m))
    d[np.arange(mf), f] = mu[f]
    v, w = nm - bm @ tm, h @ tm
    z = tm.T @ w
    n = m + 2 * mf + 2 * r
    edges = [0, m, m + mf, m + 2 * mf, m + 2 * mf + r, n]
    blocks = [[a, bm, -bm, v, -v], [d - bm.T, h, -h, -w, w], [d + bm.T, -h, h, w, -w],
              [-v.T, -w.T, w.T, z, -z], [v.T, w.T, -w.T, -z, z]]
    big = np.zeros((n, n))
    for bi, row in enumerate(blocks):
        for bj, blk in enumerate(row):
            big[edges[bi]:edges[bi + 1], edges[bj]:edges[bj + 1]] = blk
    return CoulombMatrix(big, edges, h, bm, v, w, z, f, nm, tm, dependent)
