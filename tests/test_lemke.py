"""Tests of the Lemke LCP solver (app.lcp.lemke) against brute force and the tableau reference."""

from __future__ import annotations

import importlib
import itertools
import warnings

import numpy as np
import pytest

from app.lcp import STATUSES, LCPResult, default_max_pivots, lemke
from app.lcp.cases import near_duplicate_lcp, random_contact_lcp, strip_contact_lcp
from app.lcp.lemke import _lemke_tableau

LM = importlib.import_module("app.lcp.lemke")  # the module (app.lcp.lemke is the function)
PIV = importlib.import_module("app.lcp.pivoting")  # the pivoting rules of both cores
REV = importlib.import_module("app.lcp.revised")  # the revised core and its knobs


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------


def brute_force(M: np.ndarray, q: np.ndarray, tol: float = 1e-9) -> list[np.ndarray]:
    """All solutions on nonsingular complementary bases (2^n enumeration)."""
    n = q.size
    sols = []
    for mask in itertools.product([False, True], repeat=n):
        Z = np.flatnonzero(mask)
        z = np.zeros(n)
        if Z.size:
            A = M[np.ix_(Z, Z)]
            if np.linalg.matrix_rank(A) < Z.size:
                continue
            z[Z] = np.linalg.solve(A, -q[Z])
        w = M @ z + q
        scale = 1.0 + np.abs(q).max() + np.abs(M).max() * np.abs(z).max()
        if z.min() >= -tol * scale and w.min() >= -tol * scale:
            sols.append(z)
    return sols


def assert_solution(M: np.ndarray, q: np.ndarray, res: LCPResult, rtol: float = 1e-8) -> None:
    """Independent check of a "solved" result (absolute tolerance from the data)."""
    assert res.status == "solved" and res.ok
    z, w = res.z, res.w
    scale = np.abs(q).max() + np.abs(M).max() * max(np.abs(z).max(), 1e-300)
    assert z.shape == w.shape == q.shape
    np.testing.assert_allclose(w, M @ z + q, rtol=0, atol=1e-12 * scale)
    assert z.min() >= 0.0
    assert w.min() >= -rtol * scale
    assert np.abs(z * w).max() <= rtol * scale * max(np.abs(z).max(), 1e-300)
    assert res.complementarity == pytest.approx(np.abs(z * w).max(), abs=1e-300)


def p_matrix(n: int, rng: np.random.Generator) -> np.ndarray:
    """Random P-matrix: positive definite symmetric part plus a skew part."""
    A = rng.standard_normal((n, n))
    K = rng.standard_normal((n, n))
    return A @ A.T + 0.1 * np.eye(n) + rng.uniform(0, 2) * (K - K.T)


def friction_lcp(m: int, rng: np.random.Generator, mu: float = 0.3):
    """Frictional-contact block LCP (n = 3 m) built from a random SPD compliance."""
    return random_contact_lcp(m, rng, mu)


def contact_lcp(m: int, seed: int = 0, mu: float = 0.3):
    """Larger contact-like LCP (the one of scripts/bench_lemke.py)."""
    return strip_contact_lcp(m, mu=mu, seed=seed)


# --------------------------------------------------------------------------------------
# trivial and special cases
# --------------------------------------------------------------------------------------


def test_q_nonnegative_returns_zero_without_pivots():
    M = np.array([[1.0, 2.0], [-3.0, 4.0]])
    q = np.array([0.0, 2.5])
    res = lemke(M, q)
    assert res.status == "solved" and res.ok and res.pivots == 0
    np.testing.assert_array_equal(res.z, [0.0, 0.0])
    np.testing.assert_array_equal(res.w, q)
    assert res.basis.dtype == bool and not res.basis.any()


def test_result_fields_and_one_dimensional_case():
    res = lemke(np.array([[2.0]]), np.array([-4.0]), crash=False)
    assert isinstance(res, LCPResult)
    assert res.status in STATUSES and res.ok
    np.testing.assert_allclose(res.z, [2.0], rtol=1e-14)
    np.testing.assert_allclose(res.w, [0.0], atol=1e-14)
    assert res.pivots == 2  # z0 enters, then z_1 replaces it
    assert res.basis.tolist() == [True]
    assert isinstance(res.message, str) and res.message
    assert isinstance(res.complementarity, float)
    assert default_max_pivots(10) == 600 + 2**10


def test_bad_input_raises():
    with pytest.raises(ValueError):
        lemke(np.eye(3), np.ones(2))
    with pytest.raises(ValueError):
        lemke(np.eye(2), np.array([np.nan, -1.0]))
    with pytest.raises(ValueError):
        lemke(np.eye(2), np.array([-1.0, -1.0]), basis=np.array([True]))
    for tol in (np.nan, -1e-9, 0.0, np.inf):  # it returned "inaccurate" for any z
        with pytest.raises(ValueError, match="tol must be"):
            lemke(np.eye(2), np.array([-1.0, -1.0]), tol=tol)


@pytest.mark.parametrize(
    "M, q",
    [
        (np.array([[-1.0]]), np.array([-1.0])),
        (-np.eye(3), np.array([-1.0, -2.0, -0.5])),
        (np.array([[0.0, 1.0], [-1.0, 0.0]]), np.array([-1.0, -1.0])),  # PSD, infeasible
    ],
)
def test_no_solution_gives_secondary_ray(M, q):
    assert brute_force(M, q) == []
    res = lemke(M, q)
    assert res.status == "secondary ray" and not res.ok
    assert "no solution" in res.message
    assert res.z.min() >= 0.0
    np.testing.assert_allclose(res.w, M @ res.z + q)


def test_pivot_limit():
    rng = np.random.default_rng(3)
    M = p_matrix(6, rng)
    q = -np.abs(rng.standard_normal(6)) - 0.1
    full = lemke(M, q, crash=False)
    assert full.ok and full.pivots > 2
    res = lemke(M, q, max_pivots=1, crash=False)
    assert res.status == "pivot limit" and not res.ok and res.pivots == 1
    assert res.z.min() >= 0.0
    np.testing.assert_allclose(res.w, M @ res.z + q)
    assert lemke(M, q, max_pivots=0, crash=False).status == "pivot limit"


# --------------------------------------------------------------------------------------
# brute-force comparisons on small random LCPs
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("seed", range(6))
def test_p_matrix_unique_solution_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    for _ in range(25):
        n = int(rng.integers(1, 9))
        M = p_matrix(n, rng)
        q = rng.standard_normal(n)
        sols = brute_force(M, q)
        assert len(sols) == 1  # P-matrix: exactly one solution
        res = lemke(M, q)
        assert_solution(M, q, res)
        np.testing.assert_allclose(res.z, sols[0], rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("seed", range(4))
def test_symmetric_psd_solved_iff_feasible(seed):
    rng = np.random.default_rng(100 + seed)
    n_ray = 0
    for _ in range(25):
        n = int(rng.integers(2, 9))
        G = rng.standard_normal((n, int(rng.integers(1, n + 1))))
        M = G @ G.T  # positive semidefinite, often singular
        q = rng.standard_normal(n)
        sols = brute_force(M, q)
        res = lemke(M, q)
        if sols:  # copositive-plus: Lemke must find a solution when one exists
            assert_solution(M, q, res)
        else:
            assert res.status == "secondary ray"
            n_ray += 1
    assert n_ray < 25


@pytest.mark.parametrize("seed", range(4))
def test_friction_block_matrix_matches_brute_force(seed):
    rng = np.random.default_rng(200 + seed)
    for _ in range(15):
        m = int(rng.integers(1, 3))
        M, q = friction_lcp(m, rng)
        assert not np.allclose(M, M.T)
        sols = brute_force(M, q)
        assert sols
        res = lemke(M, q)
        assert_solution(M, q, res)
        assert min(np.abs(res.z - s).max() for s in sols) <= 1e-7 * (1 + np.abs(res.z).max())


@pytest.mark.parametrize("b", [1e14, 1e20])
def test_a_variable_in_other_units_is_solved_not_passed_by_the_check_floor(b):
    """z_2 in units 1/b of the well-scaled LCP ([[2, 1], [1, 2]], q = -1): the crash's
    z = (0.5, 0) (w_2 = -0.5, a 50% error of z_1) passed the final check as "solved",
    through the round-off floor 1e-4 x max_j |M_2j| x max z taken in unscaled units."""
    M = np.array([[2.0, 1.0], [1.0, 2.0]]) @ np.diag([1.0, b])
    q = np.array([-1.0, -1.0])
    for crash in (True, False):
        res = lemke(M, q, crash=crash)
        assert res.ok, res.message
        np.testing.assert_allclose(res.z * [1.0, b], [1 / 3, 1 / 3], rtol=1e-9)


@pytest.mark.parametrize("M", [[[1e-310]], [[1e-320]], [[1.0, 0.0], [0.0, 1e-310]]])
def test_an_answer_beyond_the_float_range_is_not_solved(M):
    """z = 1e310 overflows: "solved" came back with z = inf and w = inf or nan (a nan row
    passed the check; with diag(1, 1e-310) also z_1 = 0 for 1)."""
    M = np.array(M)
    q = -np.ones(M.shape[0])
    for crash in (True, False):
        with np.errstate(all="ignore"):
            res = lemke(M, q, crash=crash)
        assert not res.ok, (res.z, res.w)


def test_degenerate_q_zeros_ties_and_duplicate_rows():
    rng = np.random.default_rng(11)
    for k in range(60):
        n = int(rng.integers(2, 8))
        A = rng.integers(-2, 3, (n, n)).astype(float)
        M = A @ A.T + (np.eye(n) if k % 2 else 0.0)  # PSD (or PD), integer entries
        if k % 3 == 0:  # duplicate row and column (a repeated contact point)
            M[:, -1] = M[:, 0]
            M[-1] = M[0]
        q = rng.integers(-2, 3, n).astype(float)  # zeros and many ratio ties
        if k % 3 == 0:
            q[-1] = q[0]
        sols = brute_force(M, q)
        res = lemke(M, q)
        _agree(res, _lemke_tableau(M, q))
        if sols:
            assert_solution(M, q, res)
        else:
            assert res.status == "secondary ray"
        B = rng.random(n) < 0.5  # degenerate warm starts: ties from the first pivot on
        _agree(lemke(M, q, basis=B), _lemke_tableau(M, q, basis=B))


@pytest.mark.parametrize(
    "M, q, B",
    [
        ([[1.5, 2.0, -1.0], [0.0, 0.5, -2.0], [2.0, 0.0, 1.5]], [-1.0, -1.0, 0.0], [1, 0, 0]),
        ([[1.5, 0.0, -2.0], [-2.0, 0.5, -1.0], [-1.0, 2.0, 3.5]], [1.0, 0.0, -2.0], [1, 0, 0]),
    ],
)
def test_degenerate_warm_start_follows_the_lexicographic_path(M, q, B):
    # ties here are broken by the rows of B^-1 B0 (B0 = warm-start basis), not of B^-1
    M, q, B = np.array(M), np.array(q), np.array(B, dtype=bool)
    res = lemke(M, q, basis=B, crash=False)
    assert_solution(M, q, res)
    assert res.warm_start == "lemke"
    _agree(res, _lemke_tableau(M, q, basis=B, crash=False))


def test_fully_degenerate_all_ties():
    # every ratio ties at every step: identical rows and columns, equal q
    n = 5
    M = np.ones((n, n)) + np.eye(n)
    q = -np.ones(n)
    res = lemke(M, q)
    assert_solution(M, q, res)
    np.testing.assert_allclose(res.z, np.full(n, 1.0 / (n + 1)), rtol=1e-12)
    M2 = np.ones((n, n))  # singular PSD, all rows duplicate
    res2 = lemke(M2, q)
    assert_solution(M2, q, res2)
    assert res2.z.sum() == pytest.approx(1.0)


# Degenerate LCPs (integer data, zeros in q) on which Lemke cycles with a naive tie-break;
# found by a random search: the lexicographic rule must solve them.
CYCLING_CASES = [
    (
        [
            [1.5, -2.0, 0.0, 1.0, 2.0],
            [1.0, 4.5, 1.0, 1.0, -2.0],
            [2.0, -2.0, 1.5, -2.0, -2.0],
            [-1.0, -1.0, 0.0, 2.5, -2.0],
            [0.0, -2.0, 2.0, -2.0, 1.5],
        ],
        [-1.0, 0.0, -1.0, 1.0, -1.0],
    ),
    (
        [[1.0, 1.0, 2.0, 0.0], [2.0, 2.0, -1.0, 0.0], [2.0, 2.0, 1.0, 1.0], [2.0, -2.0, -1.0, 0.0]],
        [-1.0, -1.0, -1.0, -1.0],
    ),
]


@pytest.mark.parametrize("case", range(len(CYCLING_CASES)))
def test_lexicographic_rule_prevents_cycling(monkeypatch, case):
    M = np.array(CYCLING_CASES[case][0])
    q = np.array(CYCLING_CASES[case][1])
    sols = brute_force(M, q)
    res = lemke(M, q, crash=False)
    assert_solution(M, q, res)
    assert any(np.allclose(res.z, s, atol=1e-9) for s in sols)
    _agree(res, _lemke_tableau(M, q, crash=False))
    # the same problem with a naive tie-break (first or last tied row) cycles
    outcomes = []
    for naive in (lambda V: 0, lambda V: V.shape[0] - 1):
        monkeypatch.setattr(PIV, "_lexmin", naive)
        outcomes.append(lemke(M, q, max_pivots=200, crash=False).status)
    assert "pivot limit" in outcomes


def test_lexmin_picks_lexicographic_minimum():
    V = np.array([[0.0, 1.0, 5.0], [0.0, 1.0, -2.0], [0.0, 3.0, -9.0], [1e-14, 1.0, -1.0]])
    assert LM._lexmin(V) == 1
    assert LM._lexmin(np.array([[2.0, 0.0], [1.0, 7.0]])) == 1
    assert LM._lexmin(np.array([[1.0, -1.0]])) == 0


# --------------------------------------------------------------------------------------
# fast (revised) version against the tableau reference
# --------------------------------------------------------------------------------------


def _random_case(kind: int, rng: np.random.Generator):
    if kind == 0:
        n = int(rng.integers(10, 50))
        A = rng.standard_normal((n, n))
        M = A @ A.T / n + 0.05 * np.eye(n) + (A - A.T) / n
        return M, rng.standard_normal(n)
    if kind == 1:
        n = int(rng.integers(10, 50))
        G = rng.standard_normal((n, n // 2))
        return G @ G.T, rng.standard_normal(n)
    return contact_lcp(int(rng.integers(5, 20)), seed=int(rng.integers(1000)))


def _agree(a: LCPResult, b: LCPResult) -> None:
    assert a.status == b.status
    assert a.pivots == b.pivots
    np.testing.assert_array_equal(a.basis, b.basis)
    scale = 1.0 + np.abs(b.z).max()
    np.testing.assert_allclose(a.z, b.z, rtol=0, atol=1e-8 * scale)


@pytest.mark.parametrize(
    "knobs",
    [
        {},
        {"_RES_REFACTOR": -1.0, "_ILL_GAP": 1},  # refactorise before every pivot
        {"_RES_REFACTOR": np.inf},  # never refactorise: the rank-1 updates alone
        {"_COMPACT_TERMS": 1, "_REFINE_EVERY": 1},  # fold every update, refine every pivot
    ],
)
def test_revised_matches_tableau_reference(monkeypatch, knobs):
    for name, value in knobs.items():
        monkeypatch.setattr(REV, name, value)
    rng = np.random.default_rng(42)
    refactorizations = pivots = 0
    for trial in range(24):
        M, q = _random_case(trial % 3, rng)
        n = q.size
        fast = lemke(M, q, crash=False)
        _agree(fast, _lemke_tableau(M, q, crash=False))
        _agree(lemke(M, q), _lemke_tableau(M, q))  # from the crash basis
        refactorizations += fast.refactorizations
        pivots += fast.pivots
        B = rng.random(n) < 0.3  # arbitrary warm start (may be singular or infeasible)
        _agree(lemke(M, q, basis=B), _lemke_tableau(M, q, basis=B))
    if knobs.get("_RES_REFACTOR") == -1.0:
        assert refactorizations > pivots / 2
    else:
        assert refactorizations == 0


def test_revised_matches_reference_on_contact_problem():
    M, q = contact_lcp(100, seed=1)
    fast = lemke(M, q, crash=False)
    ref = _lemke_tableau(M, q, crash=False)
    assert_solution(M, q, fast)
    assert fast.pivots > 50
    assert fast.refactorizations == 0  # the updated inverse stayed accurate
    _agree(fast, ref)


# --------------------------------------------------------------------------------------
# warm start
# --------------------------------------------------------------------------------------


def test_warm_start_same_basis_needs_no_pivot():
    rng = np.random.default_rng(5)
    M = p_matrix(40, rng)
    q = rng.standard_normal(40)
    cold = lemke(M, q, crash=False)
    assert cold.ok and cold.pivots > 5
    q2 = q + 1e-6 * rng.standard_normal(40)
    warm = lemke(M, q2, basis=cold.basis)
    assert_solution(M, q2, warm)
    assert warm.pivots == 0 and warm.warm_start == "accepted"
    np.testing.assert_allclose(warm.z, lemke(M, q2).z, rtol=1e-9, atol=1e-12)


def test_warm_start_fewer_pivots_when_active_set_changes():
    M, q = contact_lcp(60, seed=3)
    m = q.size // 3
    cold = lemke(M, q, crash=False)
    assert_solution(M, q, cold)
    rng = np.random.default_rng(0)
    q2 = q.copy()
    q2[:m] += 2e-3 * rng.standard_normal(m)  # next load step: gaps change a little
    warm = lemke(M, q2, basis=cold.basis, crash=False)
    cold2 = lemke(M, q2, crash=False)
    assert_solution(M, q2, warm)
    assert_solution(M, q2, cold2)
    assert not np.array_equal(cold2.basis, cold.basis)  # the active set did change
    assert warm.warm_start == "lemke"
    assert 0 < warm.pivots < cold2.pivots / 3
    np.testing.assert_allclose(warm.z, cold2.z, rtol=0, atol=1e-9 * np.abs(cold2.z).max())


def test_warm_start_bad_or_singular_basis_still_correct():
    rng = np.random.default_rng(9)
    for _ in range(20):
        n = int(rng.integers(2, 8))
        M = p_matrix(n, rng)
        q = rng.standard_normal(n)
        sol = brute_force(M, q)[0]
        for B in (rng.random(n) < 0.5, np.ones(n, dtype=bool)):
            res = lemke(M, q, basis=B)
            assert_solution(M, q, res)
            np.testing.assert_allclose(res.z, sol, rtol=1e-8, atol=1e-10)
    # duplicate columns: M_BB singular -> cold start
    M = np.array([[2.0, 2.0, 1.0], [2.0, 2.0, 1.0], [1.0, 1.0, 3.0]])
    q = np.array([-1.0, -1.0, -1.0])
    res = lemke(M, q, basis=np.array([True, True, False]))
    assert_solution(M, q, res)
    assert res.warm_start == "cold"


# --------------------------------------------------------------------------------------
# scaling and the final check
# --------------------------------------------------------------------------------------


def test_mixed_units_give_the_same_solution():
    # rows/columns in very different units (gaps in m, forces in N): LCP(S M S, S q) has
    # the solution z / S for any positive diagonal S
    M, q = contact_lcp(40, seed=2)
    base = lemke(M, q)
    assert_solution(M, q, base)
    m = q.size // 3
    S = np.concatenate([np.full(m, 1e-5), np.full(2 * m, 3e4)])
    Ms = S[:, None] * M * S[None, :]
    qs = S * q
    res = lemke(Ms, qs)
    assert res.ok and res.pivots == base.pivots
    np.testing.assert_allclose(res.z * S, base.z, rtol=1e-8, atol=1e-10 * np.abs(base.z).max())
    np.testing.assert_allclose(res.w / S, base.w, rtol=1e-6, atol=1e-9 * np.abs(base.w).max())


def test_a_wrong_candidate_is_never_reported_solved(monkeypatch):
    M = np.array([[2.0, 1.0], [0.5, 2.0]])  # not symmetric: no basis repair
    q = np.array([-1.0, 1.0])  # solution z = (0.5, 0)

    def wrong_core(M, q, d, B0, max_pivots):
        zset = np.array([False, True])  # complementary but infeasible basis
        return LM._CoreOut("solved", zset, np.array([0.0, 0.7]), 0.0, 3)

    monkeypatch.setattr(LM, "_core_revised", wrong_core)
    res = lemke(M, q, crash=False)
    assert res.status == "inaccurate" and not res.ok
    assert "fails the check" in res.message


def test_tolerance_controls_the_check():
    M = np.array([[1.0]])
    q = np.array([-1.0])
    res = lemke(M, q, tol=1e-14)
    assert_solution(M, q, res)
    assert res.z[0] == pytest.approx(1.0, rel=1e-15)


def test_warm_start_without_cold_fallback():
    """cold_start=False: a failed warm start returns at once (for trying another basis);
    the default goes on to a cold start and solves."""
    M = np.array([[4.49, -1.58, 2.8, 0.54, -3.03], [-1.24, 9.48, -0.78, -1.07, 3.99],
                  [2.07, -0.28, 2.89, 3.3, -1.08], [0.53, -0.56, 3.1, 4.21, 1.07],
                  [-3.79, 3.87, -1.78, 1.18, 16.3]])
    q = np.array([0.35, -0.59, -0.35, -0.5, 2.11])
    bad = np.array([True, False, True, True, True])
    r = lemke(M, q, basis=bad, cold_start=False, crash=False)
    assert r.status == "warm start failed" and r.warm_start == "failed" and not r.ok
    full = lemke(M, q, basis=bad, crash=False)
    assert full.ok and full.warm_start == "cold" and full.pivots > r.pivots
    w = M @ full.z + q
    assert full.z.min() >= 0 and w.min() >= -1e-12 and abs(full.z @ w) < 1e-12
    # a good basis as the second candidate of the contact solve: found without a cold start
    again = lemke(M, q, basis=full.basis, cold_start=False)
    assert again.ok and again.pivots == 0


# --------------------------------------------------------------------------------------
# pivot budget and crash basis
# --------------------------------------------------------------------------------------


def test_default_budget_lets_a_long_lemke_path_finish():
    """Murty's 12 x 12 triangular LCP: the textbook start needs 4096 pivots (2^n), more
    than the old budget 50 n + 100; the default budget lets it finish, and the crash basis
    solves it without a pivot."""
    n = 12
    M = np.tril(2.0 * np.ones((n, n)), -1) + np.eye(n)
    q = -np.ones(n)
    long_path = lemke(M, q, crash=False)
    assert_solution(M, q, long_path)
    assert long_path.pivots == 4096 > 50 * n + 100
    crashed = lemke(M, q)
    assert_solution(M, q, crashed)
    assert crashed.warm_start == "crash" and crashed.pivots == 0
    np.testing.assert_allclose(crashed.z, long_path.z, rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("seed", range(6))
def test_crash_gives_the_textbook_answer(seed):
    """P-matrices and contact LCPs (unique solutions): the crash start returns the same z
    as the textbook cold start, and names the same basis."""
    rng = np.random.default_rng(seed)
    for M, q in (friction_lcp(int(rng.integers(3, 9)), rng), contact_lcp(60, seed=seed),
                 (p_matrix(30, rng), rng.standard_normal(30))):
        cold = lemke(M, q, crash=False)
        res = lemke(M, q)
        assert_solution(M, q, res)
        assert res.warm_start in ("crash", "crash+lemke", "cold")
        scale = 1.0 + np.abs(cold.z).max()
        np.testing.assert_allclose(res.z, cold.z, rtol=0, atol=1e-9 * scale)


def test_crash_on_a_contact_lcp_needs_no_pivot():
    M, q = contact_lcp(200, seed=4)
    res = lemke(M, q)
    assert_solution(M, q, res)
    assert res.warm_start == "crash" and res.pivots == 0


def test_twins_are_the_slip_pairs():
    from app.lcp.crash import find_twins
    from app.lcp.scaling import scaling

    M, q = contact_lcp(30, seed=0)
    m = q.size // 3
    twin = find_twins(scaling(M, q)[0])
    np.testing.assert_array_equal(twin[:m], -1)  # normal unknowns have none
    np.testing.assert_array_equal(twin[m:2 * m], np.arange(2 * m, 3 * m))
    np.testing.assert_array_equal(twin[2 * m:], np.arange(m, 2 * m))


def test_bordered_block_solve_matches_a_direct_solve():
    from app.lcp.crash import _BlockSolver
    from app.lcp.scaling import scaling

    rng = np.random.default_rng(1)
    M = p_matrix(40, rng)
    q = rng.standard_normal(40)
    Ms, D, mu, nu = scaling(M, q)
    qs = D * q / nu
    solver = _BlockSolver(Ms, qs)
    Z0 = rng.random(40) < 0.5
    solver.solve(Z0)
    Z = Z0.copy()
    Z[np.flatnonzero(Z0)[:2]] = False  # two leave
    Z[np.flatnonzero(~Z0)[:1]] = True  # one joins
    z = solver.solve(Z)
    assert solver.factorizations == 1  # the change went through the bordered system
    idx = np.flatnonzero(Z)
    expect = np.zeros(40)
    expect[idx] = np.linalg.solve(Ms.dense()[np.ix_(idx, idx)], -qs[idx])
    np.testing.assert_allclose(z, expect, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("kernel", ["matern", "imq"])
@pytest.mark.parametrize("load", ["flat", "parabolic"])
def test_near_duplicate_contacts_are_solved(kernel, load):
    """Before the basis repair, 17 of these 32 LCPs ended 'inaccurate' (numerically singular
    basis, failed check) or on a false secondary ray with the textbook start."""
    for seed in range(8):
        M, q = near_duplicate_lcp(seed, kernel, load)
        assert np.linalg.cond(M) > 1e10
        for crash in (False, True):
            res = lemke(M, q, crash=crash)
            assert res.ok, (seed, crash, res.message)
            assert res.residual <= 1e-9
            rows = np.abs(q) + np.abs(M) @ res.z  # size of the terms of each w_i
            np.testing.assert_allclose(res.w, M @ res.z + q, rtol=0, atol=1e-14 * rows.max())
            assert res.z.min() >= 0 and (res.w >= -1e-9 * rows).all()
            assert (np.abs(res.w[res.z > 0]) <= 1e-9 * rows[res.z > 0]).all()


def test_a_symmetric_lcp_without_solution_still_ends_on_a_secondary_ray():
    M = np.array([[1.0, -1.0], [-1.0, 1.0]])  # PSD, singular
    q = np.array([-1.0, -1.0])  # z1 - z2 >= 1 and z2 - z1 >= 1: infeasible
    res = lemke(M, q)
    assert res.status == "secondary ray" and not res.ok


def test_block_pivoting_from_a_warm_basis():
    """A warm basis that is a few indices off: block pivoting from it finds the answer
    without a Lemke pivot; the answer is the cold one."""
    M, q = contact_lcp(60, seed=3)
    m = q.size // 3
    cold = lemke(M, q, crash=False)
    q2 = q.copy()
    q2[:m] += 2e-3 * np.random.default_rng(0).standard_normal(m)
    res = lemke(M, q2, basis=cold.basis)
    assert_solution(M, q2, res)
    assert res.warm_start == "crash" and res.pivots == 0
    ref = lemke(M, q2, crash=False)
    np.testing.assert_allclose(res.z, ref.z, rtol=0, atol=1e-9 * np.abs(ref.z).max())


@pytest.mark.parametrize("M, q", [([[1e-310]], [-1.0]),
                                  ([[1e-310, 0.0], [0.0, 1.0]], [-1.0, -1.0]),
                                  ([[5e-324, 0.0], [0.0, 1e-300]], [-2.0, 1.0])])
def test_a_solution_beyond_the_float_range_is_a_finite_inaccurate_answer(M, q):
    """z = -q / M overflows (1e310): lemke promises finite z and w and no numpy warnings;
    before, z = nan with the status 'secondary ray' ('no static equilibrium')."""
    M, q = np.array(M), np.array(q)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        res = lemke(M, q)
    assert res.status == "inaccurate" and "overflows the float range" in res.message
    assert np.isfinite(res.z).all() and np.isfinite(res.w).all()
    np.testing.assert_array_equal(res.w, M @ res.z + q)
    assert res.residual == 1.0 and not res.basis.any()


def test_a_warm_start_whose_basis_fails_the_check_is_not_said_to_have_solved_it():
    """Before: "warm start ended with 'solved' after 3 pivots; the basis became numerically
    singular after 5 pivots", which contradicts itself: the warm run reached a complementary
    basis whose answer failed the check, then the cold start's basis became singular. (A
    core that ends so, on M = I, q = (-1, -1): the same words as any core's.)"""
    from types import SimpleNamespace

    from app.lcp.lemke import _run

    ends = iter([("solved", 3), ("singular", 2)])

    def core(Ms, qs, d, B0, budget):
        status, pivots = next(ends)
        return SimpleNamespace(status=status, pivots=pivots, refactorizations=0,
                               z=np.zeros(2), zset=np.zeros(2, dtype=bool))

    r = _run(core, np.eye(2), np.array([-1.0, -1.0]), None, None,
             np.array([True, False]), crash=False)
    assert r.status == "inaccurate"
    assert r.message.startswith(
        "warm start reached a complementary basis after 3 pivots but its solution failed "
        "the check (worst relative violation "), r.message
    assert r.message.endswith("); then the cold start's basis became numerically singular "
                              "(5 pivots in all)"), r.message
    assert "'solved'" not in r.message
