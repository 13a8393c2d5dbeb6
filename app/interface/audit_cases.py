"""Adversarial LCP cases for the checker (`app.lcp.audit`, scripts/check_lcp.py): one
generator per class, each returning `Case`s with what the matrix class guarantees. (At the
interface stage because the contact cases are the interface's own `ContactLCP`.)

Guarantees: "P" (every principal minor positive: exactly one solution, Lemke finds it),
"copositive-plus" (e.g. positive semidefinite: Lemke finds a solution iff the LCP is
feasible), "none" (e.g. the frictional contact LCP: a secondary ray may hide a solution).
Plain numpy; the contact cases go through the project's own `ContactLCP` (its scaled M and
q, what `lemke` gets in a run) on compliances C = G K^-1 G^T of small spring lattices.
"""

from __future__ import annotations

import numpy as np

from app.interface.coulomb import ContactLCP
from app.lcp.audit import Case
from app.lcp.cases import p_pd


def p_triangular(n: int, rng: np.random.Generator) -> np.ndarray:
    """P-matrix that is not positive definite: positive diagonal, large random entries
    below it (principal minors: products of the diagonal), in a random symmetric order."""
    L = np.tril(rng.uniform(-5, 5, (n, n)), -1) + np.diag(rng.uniform(0.1, 2, n))
    p = rng.permutation(n)
    return L[np.ix_(p, p)]


def psd(n: int, rng: np.random.Generator, rank: int | None = None) -> np.ndarray:
    """Symmetric positive semidefinite G G^T of the given rank (default random <= n)."""
    r = int(rng.integers(1, n + 1)) if rank is None else rank
    G = rng.standard_normal((n, r))
    return G @ G.T


def psd_skew(n: int, rng: np.random.Generator) -> np.ndarray:
    """Non-symmetric, positive semidefinite (singular symmetric part plus a skew part)."""
    K = rng.standard_normal((n, n))
    return psd(n, rng, max(1, n // 2)) + (K - K.T)


def small_cases(rng: np.random.Generator, n_max: int = 10) -> list[Case]:
    """Dense random classes with n <= n_max (enumerated by the checker)."""
    out = []
    for _ in range(3):
        n = int(rng.integers(1, n_max + 1))
        q = rng.standard_normal(n)
        out.append(Case("p_pd", p_pd(n, rng), q, "P"))
        out.append(Case("p_triangular", p_triangular(n, rng), rng.standard_normal(n), "P"))
        out.append(Case("spd", psd(n, rng, n) + 1e-3 * np.eye(n), q, "P"))
        out.append(Case("psd_singular", psd(n, rng), q, "copositive-plus"))
        out.append(Case("psd_skew", psd_skew(n, rng), q, "copositive-plus"))
        out.append(Case("trivial_q_nonneg", p_pd(n, rng), np.abs(q), "P"))
    return out


def degenerate_cases(rng: np.random.Generator, n_max: int = 10) -> list[Case]:
    """Integer data (exact enumeration): q with many zeros and ties, duplicate rows and
    columns, zero rows."""
    out = []
    for _ in range(3):
        n = int(rng.integers(2, n_max + 1))
        q = rng.choice([-2.0, -1.0, -1.0, 0.0, 0.0, 0.0, 1.0], n)
        L = np.tril(rng.integers(-3, 4, (n, n)), -1) + np.diag(rng.integers(1, 3, n))
        out.append(Case("degenerate_p", L.astype(float), q, "P"))
        G = rng.integers(-2, 3, (n, max(1, n // 2))).astype(float)
        S = G @ G.T
        out.append(Case("degenerate_psd", S, q, "copositive-plus"))
        k = int(rng.integers(0, n))  # a duplicated row and column (singular blocks)
        D = S.copy()
        D[:, (k + 1) % n] = D[:, k]
        D[(k + 1) % n] = D[k]
        out.append(Case("degenerate_dup", D, q, "copositive-plus"))
        out.append(Case("degenerate_ties", np.ones((n, n)) + np.eye(n),
                        -np.ones(n) * rng.integers(0, 2), "P"))
    return out


def scaled_cases(rng: np.random.Generator, n_max: int = 10) -> list[Case]:
    """Rows (R M, R q: the same solutions) and symmetric scalings (D M D, D q: z / D) by
    factors 1e-8..1e8 of P and contact LCPs."""
    out = []
    for _ in range(3):
        n = int(rng.integers(2, n_max + 1))
        M, q = p_pd(n, rng), rng.standard_normal(n)
        R = 10.0 ** rng.uniform(-8, 8, n)
        out.append(Case("scaled_rows_p", R[:, None] * M, R * q, "P", ref=(M, q),
                        scale=np.ones(n)))
        D = 10.0 ** rng.uniform(-8, 8, n)
        out.append(Case("scaled_sym_p", D[:, None] * M * D, D * q, "P", ref=(M, q), scale=D))
        Mc, qc, _ = contact_case(rng, int(rng.integers(1, 4)), mu=0.3)
        R = 10.0 ** rng.uniform(-8, 8, qc.size)
        out.append(Case("scaled_rows_contact", R[:, None] * Mc, R * qc, "none", ref=(Mc, qc),
                        scale=np.ones(qc.size)))
    return out


def infeasible_cases(rng: np.random.Generator, n_max: int = 10) -> list[Case]:
    """LCPs built to have no solution (a row i with M_ij <= 0 for all j and q_i < 0; a PSD
    block [[1, -1], [-1, 1]] with q = (-1, -1)): every solver must not say solved."""
    out = []
    for _ in range(3):
        n = int(rng.integers(2, n_max + 1))
        M = p_pd(n, rng)
        i = int(rng.integers(n))
        M[i] = -np.abs(M[i]) * rng.integers(0, 2, n)
        q = rng.standard_normal(n)
        q[i] = -abs(q[i]) - 0.1
        out.append(Case("infeasible_row", M, q, "none", expect="infeasible"))
        k = max(n - 2, 1)
        S = np.zeros((k + 2, k + 2))
        S[:k, :k] = psd(k, rng)
        S[k:, k:] = [[1.0, -1.0], [-1.0, 1.0]]
        qs = np.concatenate([rng.standard_normal(k), [-1.0, -1.0]])
        out.append(Case("infeasible_psd", S, qs, "copositive-plus", expect="infeasible"))
    return out


# ---- contact LCPs on spring lattices -------------------------------------------------


def lattice_stiffness(nx: int, ny: int, k: float = 1.0) -> np.ndarray:
    """Stiffness (2N, 2N) of an nx x ny lattice of unit spacing with axial springs along
    the edges and both diagonals (stiffness k); DOFs (ux, uy) per node, node = j nx + i
    (row j = 0 at the bottom). Singular: its null space holds the 3 rigid modes."""
    N = nx * ny
    K = np.zeros((2 * N, 2 * N))
    xy = np.array([(i, j) for j in range(ny) for i in range(nx)], dtype=float)
    for a in range(N):
        for b in range(a + 1, N):
            d = xy[b] - xy[a]
            if np.abs(d).max() > 1.0:
                continue
            e = d / np.linalg.norm(d)
            ke = k * np.outer(e, e)
            ia, ib = slice(2 * a, 2 * a + 2), slice(2 * b, 2 * b + 2)
            K[ia, ia] += ke
            K[ib, ib] += ke
            K[ia, ib] -= ke
            K[ib, ia] -= ke
    return K


def rigid_modes(nx: int, ny: int) -> np.ndarray:
    """(2N, 3) rigid modes of the lattice: x, y translations and the rotation, orthonormal."""
    xy = np.array([(i, j) for j in range(ny) for i in range(nx)], dtype=float)
    R = np.zeros((2 * xy.shape[0], 3))
    R[0::2, 0] = 1.0
    R[1::2, 1] = 1.0
    c = xy - xy.mean(axis=0)
    R[0::2, 2], R[1::2, 2] = -c[:, 1], c[:, 0]
    return np.linalg.qr(R)[0]


def contact_case(rng: np.random.Generator, m: int, mu: float, floating: bool = False,
                 soft: float = 1.0, duplicate: bool = False, push: float = 0.0,
                 lift: bool = False) -> tuple[np.ndarray, np.ndarray, int]:
    """(M, q, r) of `ContactLCP` for a lattice of m x 3 nodes on a rigid floor: its bottom
    nodes are the m slave pairs (normal uy, tangent ux). Supported at the top row, or
    floating (the 3 rigid modes as LCP unknowns, K made regular by + R R^T). soft: the
    stiffness of the bottom row's springs relative to 1 (1e-8: a nearly singular C);
    duplicate: the last pair repeats the first's rows (a singular C); push: a side load on
    the top row; lift: the load pulls the body up (no equilibrium when floating)."""
    nx, ny = max(m, 2), 3
    K = lattice_stiffness(nx, ny)
    if soft != 1.0:
        Kb = lattice_stiffness(nx, 1)
        K[: 2 * nx, : 2 * nx] += (soft - 1.0) * Kb
    N = nx * ny
    f = np.zeros(2 * N)
    top = np.arange(nx * (ny - 1), N)
    f[2 * top + 1] = (1.0 if lift else -1.0) * rng.uniform(0.5, 1.5, nx)
    f[2 * top] = push
    R = rigid_modes(nx, ny)
    Kr, u0 = _regular_and_free(rng, K, R, f, top, floating)
    G = _pair_rows(m, nx, N, duplicate)
    C = G @ np.linalg.solve(Kr, G.T)
    C = 0.5 * (C + C.T)
    g0 = rng.uniform(0.0, 0.3, m)
    gap_free, tau_free = g0 + G[:m] @ u0, G[m:] @ u0
    mus = np.full(m, mu)
    a = rng.uniform(0, 0.2, m) * (rng.random(m) < 0.3)
    c = mu * a + rng.uniform(0, 0.1, m) * (rng.random(m) < 0.5)
    nm = G[:m] @ R if floating else None
    tm = G[m:] @ R if floating else None
    lcp = ContactLCP(C, mus, np.full(m, mu > 0 or bool(c.any())), nm, tm)
    e0 = R.T @ f if floating else np.zeros(0)
    q = lcp.constant(gap_free, tau_free, np.zeros(m), a, c, mus, e0)
    qs = lcp.scaling * lcp.row_scale * q
    return lcp.M_scaled.copy(), qs, 0 if nm is None else 3


def _regular_and_free(rng: np.random.Generator, K: np.ndarray, R: np.ndarray, f: np.ndarray,
                      top: np.ndarray, floating: bool) -> tuple[np.ndarray, np.ndarray]:
    """(Kr, u0): the regular stiffness (2N, 2N) and the displacement without contact (2N,)
    under the loads f. Floating: Kr = K + R R^T and f less its rigid-mode part; else the
    top row held (its rows and columns replaced by the identity) and a random body load
    in [-1, 0) added at the free DOFs."""
    if floating:
        Kr = K + R @ R.T
        return Kr, np.linalg.solve(Kr, f - R @ (R.T @ f))
    free = np.ones(K.shape[0], dtype=bool)
    free[np.concatenate([2 * top, 2 * top + 1])] = False
    Kr = K.copy()
    Kr[~free] = 0.0
    Kr[:, ~free] = 0.0
    Kr[~free, ~free] = 1.0
    u0 = np.linalg.solve(Kr, np.where(free, f + rng.uniform(-1, 0, K.shape[0]) * free, 0.0))
    return Kr, u0


def _pair_rows(m: int, nx: int, N: int, duplicate: bool) -> np.ndarray:
    """G (2m, 2N): the normal (uy) rows of the m slave nodes of the bottom row, then their
    tangential (ux) rows; with duplicate, the last pair repeats the first's node."""
    slaves = np.arange(m) % nx
    if duplicate and m > 1:
        slaves[-1] = slaves[0]
    G = np.zeros((2 * m, 2 * N))
    G[np.arange(m), 2 * slaves + 1] = 1.0
    G[m + np.arange(m), 2 * slaves] = 1.0
    return G


def contact_cases(rng: np.random.Generator) -> list[Case]:
    """The modified Coulomb LCP of `contact_case`: supported and floating bodies, mu 0
    (positive semidefinite: copositive-plus) and 0.3, 1 (no guarantee), nearly singular and
    singular compliances, and bodies pulled off the floor (no equilibrium)."""
    out = []
    for _ in range(2):
        for mu in (0.0, 0.3, 1.0):
            g = "copositive-plus" if mu == 0 else "none"
            m = int(rng.integers(1, 4))
            M, q, _ = contact_case(rng, m, mu)
            out.append(Case(f"contact_mu{mu:g}", M, q, g))
            M, q, _ = contact_case(rng, 2, mu, floating=True)
            out.append(Case(f"contact_floating_mu{mu:g}", M, q, g))
            M, q, _ = contact_case(rng, m, mu, soft=1e-8)
            out.append(Case(f"contact_nearly_singular_mu{mu:g}", M, q, g))
            M, q, _ = contact_case(rng, 3, mu, duplicate=True)
            out.append(Case(f"contact_singular_C_mu{mu:g}", M, q, g))
            M, q, _ = contact_case(rng, 2, mu, floating=True, lift=True)
            out.append(Case(f"contact_lifted_mu{mu:g}", M, q, g, expect="infeasible"))
        M, q, _ = contact_case(rng, 2, 0.3, floating=True, push=50.0)
        out.append(Case("contact_pushed_off_mu0.3", M, q, "none"))
    return out


def large_cases(rng: np.random.Generator) -> list[Case]:
    """Larger LCPs (n 30-150; checked by the KKT residual, and for copositive-plus
    classes against LP feasibility)."""
    out = []
    n = int(rng.integers(30, 151))
    q = rng.standard_normal(n)
    out.append(Case("large_p_pd", p_pd(n, rng), q, "P"))
    out.append(Case("large_psd_singular", psd(n, rng, n // 3), q, "copositive-plus"))
    out.append(Case("large_psd_skew", psd_skew(n, rng), q, "copositive-plus"))
    R = 10.0 ** rng.uniform(-8, 8, n)
    M = p_pd(n, rng)
    out.append(Case("large_scaled_rows_p", R[:, None] * M, R * q, "P"))
    M, q, _ = contact_case(rng, int(rng.integers(10, 40)), 0.3)
    out.append(Case("large_contact_mu0.3", M, q, "none"))
    M, q, _ = contact_case(rng, int(rng.integers(10, 40)), 0.0, soft=1e-8)
    out.append(Case("large_contact_nearly_singular_mu0", M, q, "copositive-plus"))
    return out


def warm_variants(case: Case, rng: np.random.Generator,
                  solution: np.ndarray | None) -> list[Case]:
    """The case again with warm-start bases: random, all basic, the solution's basis and
    its complement, the solution's basis with its degenerate indices (z_i = w_i = 0)
    flipped, each with cold_start True and False; and bases of the wrong size (ValueError)."""
    n = case.q.size
    bases = [rng.random(n) < 0.5, np.ones(n, dtype=bool)]
    if solution is not None:
        S = solution > 0
        w = case.M @ solution + case.q
        deg = (solution == 0) & (np.abs(w) <= 1e-12 * (1 + np.abs(case.q).max()))
        bases += [S, ~S, S ^ deg]
    out = []
    for b in bases:
        for cold in (True, False):
            out.append(Case(f"warm_{case.cls}", case.M, case.q, case.guarantee,
                            {"basis": b, "cold_start": cold}, case.ref, case.scale,
                            expect=case.expect))
    for size in (n - 1, n + 1):
        if size >= 0:
            out.append(Case("warm_wrong_size", case.M, case.q, case.guarantee,
                            {"basis": np.ones(size, dtype=bool)}, error=True))
    return out


def structured_cases(rng: np.random.Generator, n_max: int = 10) -> list[Case]:
    """Zero diagonals and twins: the KKT LCP of a random LP (skew-symmetric: PSD),
    bimatrix games (a Nash equilibrium exists), negated column pairs at random places
    (the crash's twins outside the contact layout), nearly singular P-matrices and
    data near the ends of the float range (1e-100..1e100)."""
    out = []
    for _ in range(2):
        k = int(rng.integers(1, n_max // 2 + 1))
        A = rng.standard_normal((k, k))
        c, b = rng.standard_normal(k), rng.standard_normal(k)
        Z = np.zeros((k, k))
        out.append(Case("lp_kkt", np.block([[Z, -A.T], [A, Z]]), np.concatenate([c, -b]),
                        "copositive-plus"))
        Ag, Bg = rng.uniform(0.1, 1, (k, k)), rng.uniform(0.1, 1, (k, k))
        out.append(Case("bimatrix", np.block([[Z, Ag], [Bg.T, Z]]), -np.ones(2 * k), "none"))
        n = int(rng.integers(2, n_max // 2 + 1))
        G = rng.standard_normal((n, n))
        S = np.hstack([G, -G])  # columns i and n + i negated: twins
        p = rng.permutation(2 * n)
        M = (S.T @ S + np.kron([[1, -1], [-1, 1]], 1e-3 * np.eye(n)))[np.ix_(p, p)]
        out.append(Case("twins_random", M, rng.standard_normal(2 * n), "copositive-plus"))
        n = int(rng.integers(2, n_max + 1))
        U = np.linalg.qr(rng.standard_normal((n, n)))[0]
        M = U @ np.diag(np.logspace(0, -10, n)) @ U.T
        out.append(Case("nearly_singular_p", M, rng.standard_normal(n), "P"))
        M0, q0 = p_pd(n, rng), rng.standard_normal(n)
        s, t = 10.0 ** rng.choice([-100, 100], 2)
        out.append(Case("extreme_magnitude", s * M0, t * q0, "P", ref=(M0, q0),
                        scale=np.full(n, s / t)))
    return out


def large_twin_cases(rng: np.random.Generator) -> list[Case]:
    """n 300-420 with twins at random places (the crash's sampled probe reads 128 rows for
    n > 256) and a contact LCP with shuffled unknowns."""
    n = int(rng.integers(150, 211))
    G = rng.standard_normal((n, n)) / np.sqrt(n)
    S = np.hstack([G, -G])
    p = rng.permutation(2 * n)
    M = (S.T @ S + np.kron([[1, -1], [-1, 1]], 1e-2 * np.eye(n)))[np.ix_(p, p)]
    out = [Case("large_twins_random", M, rng.standard_normal(2 * n), "copositive-plus")]
    Mc, qc, _ = contact_case(rng, int(rng.integers(100, 141)), 0.0)
    p = rng.permutation(qc.size)
    out.append(Case("large_contact_shuffled_mu0", Mc[np.ix_(p, p)], qc[p], "copositive-plus"))
    return out


GROUPS = (("warm_wrong_size", "wrong-size bases"), ("warm_", "warm starts (all classes)"),
          ("large_", "large (n 30-420)"), ("infeasible", "infeasible"),
          ("contact_lifted", "infeasible"), ("contact", "contact (modified Coulomb)"),
          ("scaled", "badly scaled"), ("extreme", "badly scaled"),
          ("degenerate", "degenerate (integer, ties, zeros)"), ("bimatrix", "bimatrix games"),
          ("psd", "positive semidefinite"), ("lp_kkt", "positive semidefinite"),
          ("twins", "positive semidefinite"), ("", "P-matrices"))
"""(class prefix, group) for the checker's summary by group; the first match counts."""


def group(cls: str) -> str:
    """The summary group of a case class (`GROUPS`)."""
    return next(g for prefix, g in GROUPS if cls.startswith(prefix))
