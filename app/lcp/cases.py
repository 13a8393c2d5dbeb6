"""Frictional-contact LCP test cases, shared by tests/test_lemke.py and
scripts/bench_lemke.py: the modified Coulomb block matrix (app/lcp/coulomb_matrix.py) of
a given compliance, with q from seeded random gaps, strengths and tangential loads.
Plain numpy; no mesh, no PETSc, no interface stage."""

from __future__ import annotations

import numpy as np

from app.lcp.coulomb_matrix import coulomb_matrix


def coulomb_lcp_matrix(C: np.ndarray, mu: float) -> np.ndarray:
    """The modified Coulomb LCP matrix (3m, 3m) of compliance C (2m, 2m), every pair
    frictional with coefficient mu."""
    m = C.shape[0] // 2
    return coulomb_matrix(C, np.full(m, mu), np.ones(m, dtype=bool)).M


def strip_compliance(m: int) -> np.ndarray:
    """SPD compliance (2m, 2m) of a 1D elastic strip: a Laplace kernel
    (10 / m) exp(-|x_i - x_j| / 0.1) on m equally spaced points for C_nn and 1.2 x it for
    C_tt, plus 0.05 I, and a weak antisymmetric coupling C_nt."""
    x = np.linspace(0.0, 1.0, m)
    r = x[:, None] - x[None, :]
    k = np.exp(-np.abs(r) / 0.1) * (10.0 / m)
    c_nt = 0.03 * np.sign(r) * k  # spectral norm < 0.05: C stays SPD
    return np.block([[k + 0.05 * np.eye(m), c_nt], [c_nt.T, 1.2 * k + 0.05 * np.eye(m)]])


def strip_contact_lcp(m: int, *, mu: float = 0.3, seed: int = 0) -> tuple[np.ndarray,
                                                                        np.ndarray]:
    """(M, q), n = 3 m: the strip compliance, gaps in [-1e-2, 5e-3] (partly penetrating),
    strengths in [0, 0.05] and tangential loads in [-0.1, 0.1]."""
    rng = np.random.default_rng(seed)
    M = coulomb_lcp_matrix(strip_compliance(m), mu)
    gap0 = rng.uniform(-1.0, 0.5, m) * 1e-2
    c = rng.uniform(0.0, 0.05, m)
    s = rng.uniform(-0.1, 0.1, m)
    return M, np.concatenate([gap0, c + s, c - s])


def random_contact_lcp(m: int, rng: np.random.Generator,
                       mu: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """(M, q), n = 3 m, from a random SPD compliance G G^T / 2m + 0.2 I."""
    G = rng.standard_normal((2 * m, 2 * m))
    M = coulomb_lcp_matrix(G @ G.T / (2 * m) + 0.2 * np.eye(2 * m), mu)
    c = rng.uniform(0.0, 0.5, m)
    s = rng.uniform(-1.0, 1.0, m)
    return M, np.concatenate([rng.uniform(-1.0, 1.0, m), c + s, c - s])


def near_duplicate_lcp(seed: int, kernel: str, load: str) -> tuple[np.ndarray, np.ndarray]:
    """(M, q), n = 50: frictionless contacts on a line, 10 of them 1e-5 from another, a
    smooth SPD compliance kernel ("matern" or "imq"), condition 1e10 to 1e12, a unique
    solution; load "flat" (q = -1) or "parabolic" (tests/test_lemke.py and the
    benchmarks use it)."""
    rng = np.random.default_rng(seed)
    x = np.linspace(-1.0, 1.0, 40)
    x = np.sort(np.concatenate([x, x[rng.choice(40, 10, replace=False)] + 1e-5]))
    d = np.abs(x[:, None] - x[None, :])
    M = np.exp(-d / 0.3) * (1 + d / 0.3) if kernel == "matern" else 1 / np.sqrt(1 + (d / 0.1)**2)
    q = -np.ones(50) if load == "flat" else 0.5 * x**2 - 0.3
    return M, q


def p_pd(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, n) P-matrix: positive definite symmetric part plus a skew part."""
    A = rng.standard_normal((n, n))
    K = rng.standard_normal((n, n))
    return A @ A.T / n + 0.05 * np.eye(n) + rng.uniform(0, 3) * (K - K.T)


def row_scaled_lcp(seed: int, n: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """(R M, R q): a P-matrix LCP (`p_pd`) with its rows scaled by 10^U(-8, 8): the
    solutions of (M, q)."""
    rng = np.random.default_rng(seed)
    M = p_pd(n, rng)
    q = rng.standard_normal(n)
    R = 10.0 ** rng.uniform(-8, 8, n)
    return R[:, None] * M, R * q
