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

FIXED_REL = 1e-20
"""A pair's normal (tangential) compliance below this x the largest is round-off of a
motion the supports fix: with the Dirichlet rows and columns eliminated the prescribed
displacements are exactly zero, and only round-off weights (~1e-16) of the pair's G on free
dofs give it a compliance, ~1e-32 of the largest. Not DEPENDENT_REL (1e-10): a legitimate
pair between bodies 1e11 times stiffer than those of another interface was taken for fixed
(`tests/test_interface_steps.py`, stiff interface)."""

FIXED_COMPLIANCE_REL = 1e-12
"""The compliance given to such a pair (`tie_fixed`), relative to the largest of its block:
a stiff tie, decoupled from the other pairs."""

DEPENDENT_REL = 1e-10
"""Eigenvalues of the Jacobi-scaled tangential compliance (unit diagonal) below this x the
largest span its null space."""

NULL_STIFFNESS_REL = 1e9
"""Stiffness on that null space, relative to the largest scaled stiffness 1 / lambda_min
kept."""


def fixed_rows(diag: np.ndarray) -> tuple[np.ndarray, float]:
    """(fixed (k,) bool, tie): the rows of a compliance block (diagonal diag, (k,)) whose
    compliance is round-off, at most FIXED_REL x the largest (or not positive), and the
    compliance FIXED_COMPLIANCE_REL x the largest that `tie_fixed` gives them (0 and no
    row fixed when no diagonal entry is positive)."""
    top = float(diag.max(initial=0.0))
    if not top > 0:
        return np.zeros(diag.size, dtype=bool), 0.0
    return diag <= FIXED_REL * top, FIXED_COMPLIANCE_REL * top


def tie_fixed(c: np.ndarray, rows: np.ndarray, tie: float) -> np.ndarray:
    """A copy of compliance c with its rows and columns `rows` (indices) zeroed and `tie` on
    their diagonal: a stiff spring, decoupled from the other rows, where the supports fix the
    motion (its force moves nothing, so any value is an answer; the tie picks 0)."""
    c = c.copy()
    c[rows, :] = 0.0
    c[:, rows] = 0.0
    c[rows, rows] = tie
    return c


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
    h_range: np.ndarray | None = None
    tie: np.ndarray | None = None

    def apply_h(self, x: np.ndarray) -> np.ndarray:
        """H x (x (mf,) or (mf, k)) as h_range x + tie (tie^T x) (`tangential_parts`): the
        summed force of dependent rows exact to round-off, not to eps x the tie."""
        if self.tie is None or self.tie.shape[1] == 0:
            return self.h @ x
        return self.h_range @ x + self.tie @ (self.tie.T @ x)


def tangential_stiffness(ctt: np.ndarray) -> tuple[np.ndarray, int]:
    """(H, n_dependent): H = C_tt^-1, (mf, mf), and the number of dependent directions
    (`tangential_parts` summed)."""
    h_range, tie, dependent = tangential_parts(ctt)
    h = h_range + tie @ tie.T if tie.shape[1] else h_range
    return 0.5 * (h + h.T), dependent


def tangential_parts(ctt: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """(H_range, tie, n_dependent) with H = H_range + tie tie^T = C_tt^-1 (mf, mf), tie
    (mf, n_null) = sqrt(k0) D^-1/2 N0 (empty without a null space).

    C_tt is singular when tangential rows of G are dependent on the free DOFs: a pair
    whose tangential motion is fixed by supports (a zero or round-off row: `fixed_rows`,
    tied by `tie_fixed`), or two pairs whose slave tangential DOFs are fixed and which
    project onto the same master point (equal rows). The tangential forces along such a
    direction do not move anything: they are not unique. Dependence is judged on the
    Jacobi-scaled S = D^-1/2 C_tt D^-1/2 (D = diag C_tt, S has a unit diagonal), so that
    each pair is measured against its own compliance: an interface between bodies 1e11
    times stiffer than another's is not taken for a null space (its eigenvalues of C_tt
    are ~1e-11 of the largest; unscaled, q there was 99% off). H = D^-1/2 S^+ D^-1/2 with
    S^+ = V diag(1/lambda) V^T + k0 N0 N0^T on S's eigenvectors, k0 = NULL_STIFFNESS_REL x
    the largest kept 1/lambda: a stiff tie on the null space N0, so the LCP stays regular
    and picks one of the equivalent force splits, while the displacements, which come
    from C, are exact. The count includes the fixed rows. The tie is kept apart: summed
    into H, its entries (k0 / 2 on the two rows of a pair of equal rows) carry round-off
    eps x k0, and the summed force of such rows was exact to only 1.5e-7 (eps x 1e9);
    products with H taken part by part (`CoulombMatrix.apply_h`) keep it to round-off.
    """
    ctt = 0.5 * (ctt + ctt.T)
    if not np.isfinite(ctt).all():
        raise SolveError("the tangential contact compliance is not finite: check the "
                         "Young's moduli and the loads")
    fixed, tie = fixed_rows(np.diagonal(ctt))
    if tie == 0.0:
        raise SolveError("the tangential compliance of every frictional pair is zero: their "
                         "tangential motion is fixed by supports; set mu = 0 on the interface")
    if fixed.any():
        ctt = tie_fixed(ctt, np.flatnonzero(fixed), tie)
    root = np.sqrt(np.diagonal(ctt))
    hs, ns, dependent = _unit_diagonal_inverse(ctt / root[:, None] / root[None, :])
    h = hs / root[:, None] / root[None, :]
    return 0.5 * (h + h.T), ns / root[:, None], dependent + int(fixed.sum())


def _unit_diagonal_inverse(s: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """(S^+ on the range, sqrt(k0) N0 (n, n_null), n_null) of a symmetric positive
    semidefinite S with unit diagonal: S^-1 by Cholesky when its smallest pivot^2 is
    above DEPENDENT_REL, else from the eigenvectors with a stiff tie k0 N0 N0^T on the
    null space (see `tangential_stiffness`)."""
    try:
        fac = cho_factor(s)
        ok = float(np.diag(fac[0]).min()) ** 2 > DEPENDENT_REL
        if ok:  # Cholesky can pass a numerically singular S: the pivot check above
            h = cho_solve(fac, np.eye(s.shape[0]))
            ok = bool(np.all(np.isfinite(h)))
    except np.linalg.LinAlgError:
        ok = False
    if ok:
        return h, np.zeros((s.shape[0], 0)), 0
    try:
        lam, vec = np.linalg.eigh(s)
    except np.linalg.LinAlgError:
        raise SolveError("the tangential contact compliance has no eigen-decomposition "
                         "(non-finite or badly scaled values): check the Young's moduli and "
                         "the loads") from None
    keep = lam > DEPENDENT_REL * float(lam.max())  # lam.max() >= 1: unit diagonal
    vk, vn = vec[:, keep], vec[:, ~keep]
    k0 = NULL_STIFFNESS_REL / float(lam[keep].min())
    return (vk / lam[keep]) @ vk.T, np.sqrt(k0) * vn, int((~keep).sum())


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
    h_range, tie, dependent = tangential_parts(ctt) if mf else \
        (np.zeros((0, 0)), np.zeros((0, 0)), 0)
    h = h_range + tie @ tie.T if tie.shape[1] else h_range
    h = 0.5 * (h + h.T)
    # the products part by part: the tie's round-off (eps x k0) stays in the H block
    bm = cnt @ h_range + (cnt @ tie) @ tie.T if tie.shape[1] else cnt @ h  # (m, mf)
    a = cnn - bm @ cnt.T
    a = 0.5 * (a + a.T)
    d = np.zeros((mf, m))
    d[np.arange(mf), f] = mu[f]
    w = h_range @ tm + tie @ (tie.T @ tm) if tie.shape[1] else h @ tm
    v = nm - bm @ tm
    z = tm.T @ w
    n = m + 2 * mf + 2 * r
    edges = [0, m, m + mf, m + 2 * mf, m + 2 * mf + r, n]
    blocks = [[a, bm, -bm, v, -v], [d - bm.T, h, -h, -w, w], [d + bm.T, -h, h, w, -w],
              [-v.T, -w.T, w.T, z, -z], [v.T, w.T, -w.T, -z, z]]
    big = np.zeros((n, n))
    for bi, row in enumerate(blocks):
        for bj, blk in enumerate(row):
            big[edges[bi]:edges[bi + 1], edges[bj]:edges[bj + 1]] = blk
    return CoulombMatrix(big, edges, h, bm, v, w, z, f, nm, tm, dependent,
                         h_range if tie.shape[1] else None, tie if tie.shape[1] else None)
