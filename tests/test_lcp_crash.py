"""The kernels of the cold Lemke start (app/lcp/crash.py, app/lcp/scaling.py, the final
check of app/lcp/lemke.py): each against a plain reference, and the two-stage crash
against the textbook start on LCPs of the benchmark kind and on hard cases."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from app.lcp import lemke
from app.lcp.cases import random_contact_lcp, strip_contact_lcp
from app.lcp.crash import (
    _factor,
    _first_stage,
    _symmetric,
    _twin_range,
    _twin_stage,
    _TwinProduct,
    column_probe,
    crash_basis,
    find_twins,
    twins_from_probe,
)
from app.lcp.scaling import ScaledM, diagonal_scaling, gather, scaling
from tests.test_lemke import assert_solution, near_duplicate_lcp, p_matrix

LM = importlib.import_module("app.lcp.lemke")


def _old_check(M, q, z, tol):
    """The final check as it was before issue 12's speed-up: row sizes on every row."""
    w = M @ z + q
    a = np.abs(M)
    row_max = a.max(axis=1)
    s = np.abs(q) + a @ z
    z_scale = max(float(z.max()), float(np.abs(q).max()) / row_max.max())
    s = np.maximum(s, 1e-4 * row_max * z_scale)
    viol = np.maximum(np.maximum(-w, 0.0), np.where(z > 0, np.abs(w), 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(viol > 0, viol / s, 0.0)
    worst = float(rel.max())
    return w, bool((z >= 0).all() and worst <= tol), float(np.abs(z * w).max()), worst


@pytest.mark.parametrize("seed", range(6))
def test_check_on_violated_rows_equals_the_check_on_every_row(seed):
    rng = np.random.default_rng(seed)
    M, q = random_contact_lcp(20, rng)
    z = np.where(rng.random(q.size) < 0.4, rng.random(q.size), 0.0)
    if seed % 2:  # tiny z: max |q| / max |M| sets the floor, read from all of M
        z *= 1e-9
    z[:3] = 0.0
    q[:3] = -(M[:3] @ z)  # w = 0 exactly where z = 0: rows without violation
    new, old = LM._check(M, q, z, 1e-9), _old_check(M, q, z, 1e-9)
    np.testing.assert_array_equal(new[0], old[0])
    assert new[1] == old[1] and new[2] == old[2]
    assert new[3] == pytest.approx(old[3], rel=1e-12, abs=0.0)


def test_validation_finds_non_finite_entries_and_accepts_huge_finite_ones():
    M = np.eye(4)
    for bad in (np.nan, np.inf, -np.inf):
        B = M.copy()
        B[1, 3] = bad
        with pytest.raises(ValueError, match="finite"):
            lemke(B, -np.ones(4))
    H = np.diag([1e308, 1e308, 1.0, 1.0])
    H[0, 1] = H[1, 0] = 1e308  # the probe overflows; M itself is finite
    assert np.isfinite(LM._validate(H, -np.ones(4))[0]).all()


def test_probe_twins_and_first_stage_of_the_contact_layout():
    M, q = strip_contact_lcp(30, seed=2)
    m = 30
    Ms, _, _ = diagonal_scaling(M, q)
    twin = twins_from_probe(column_probe(M, Ms.D))
    np.testing.assert_array_equal(twin, find_twins(scaling(M, q)[0]))
    np.testing.assert_array_equal(twin[m:2 * m], np.arange(2 * m, 3 * m))
    assert _first_stage(twin) == slice(0, m)
    assert _first_stage(np.full(5, -1)) is None  # no twins: one stage
    assert _first_stage(np.array([-1, 2, 1, -1])) is None  # lone indices not one range


@pytest.mark.parametrize("layout", ["contact", "modes", "scattered"])
def test_twin_product_equals_the_plain_product(layout):
    rng = np.random.default_rng(4)
    M, q = strip_contact_lcp(40, seed=1)
    if layout == "modes":  # [p, s+, s-, a+, a-]: two ranges of kept columns
        c = rng.standard_normal((M.shape[0], 1))
        r = rng.standard_normal((1, M.shape[0]))
        r[0, 80:] = -r[0, 40:80]  # the rows keep s- = -s+
        M = np.block([[M, c, -c], [r, np.array([[1.0, -1.0]])], [-r, np.array([[-1.0, 1.0]])]])
        q = np.append(q, [0.1, 0.2])
    if layout == "scattered":
        perm = rng.permutation(q.size)
        M, q = M[np.ix_(perm, perm)], q[perm]
    Ms, _, _ = diagonal_scaling(M, q)
    twin = find_twins(Ms)
    product = _TwinProduct(Ms, twin)
    assert (product.runs is None) == (layout == "scattered")
    if layout == "modes":
        assert len(product.runs) == 2
    for _ in range(3):
        z = np.where(rng.random(q.size) < 0.5, rng.random(q.size), 0.0)
        ref = Ms.matvec(z)
        np.testing.assert_allclose(product(z), ref, rtol=0, atol=1e-13 * np.abs(ref).max())


def test_factor_uses_cholesky_only_for_symmetric_positive_definite_blocks():
    rng = np.random.default_rng(0)
    G = rng.standard_normal((30, 30))
    spd = G @ G.T + np.eye(30)
    b = rng.standard_normal(30)
    for A, chol in ((spd, True), (spd + 0.5 * (G - G.T), False), (-spd, False)):
        assert _symmetric(A) == bool(np.array_equal(A, A.T))
        f = _factor(A.copy(), cholesky=True)  # (overwrites its argument)
        assert f.cholesky == chol
        np.testing.assert_allclose(A @ f.solve(b), b, rtol=0, atol=1e-10)
    singular = spd.copy()
    singular[:, 0] = singular[:, 1]
    singular[0] = singular[1]
    assert _factor(singular, cholesky=True) is None


def test_symmetric_block_of_the_first_stage_is_solved_by_cholesky():
    M, q = strip_contact_lcp(50, seed=0)
    Ms, qs, _ = diagonal_scaling(M, q)
    Z = np.flatnonzero(qs[:50] < 0)
    A = Ms.sub(Z)
    assert _symmetric(A) and _factor(A, cholesky=True).cholesky


def test_a_failed_cholesky_leaves_the_block_for_the_lu():
    """Symmetric but indefinite: Cholesky fails half way, the upper triangle is restored
    from the lower one and the LU solves the original block."""
    rng = np.random.default_rng(2)
    G = rng.standard_normal((40, 40))
    A = G + G.T  # symmetric, indefinite
    b = rng.standard_normal(40)
    f = _factor(A.copy(), cholesky=True)
    assert not f.cholesky
    np.testing.assert_allclose(A @ f.solve(b), b, rtol=0, atol=1e-9)


def test_diagonal_scaling_is_the_full_scaling_up_to_mu():
    M, q = strip_contact_lcp(40, seed=3)
    Mc, qc, zfac = diagonal_scaling(M, q)
    Ms, D, mu, nu = scaling(M, q)
    np.testing.assert_array_equal(Mc.D, D)  # no tiny diagonal here: the same D
    np.testing.assert_array_equal(qc, D * q / nu)
    np.testing.assert_array_equal(zfac, D * nu)
    np.testing.assert_allclose(Mc.dense(), mu * Ms.dense(), rtol=1e-15)
    M0 = M.copy()
    M0[0, 0] = 0.0  # zero diagonal: D_i = 1 there, still a valid (finite) scaling
    assert diagonal_scaling(M0, q)[0].D[0] == 1.0


def test_partial_products_of_the_scaled_matrix():
    rng = np.random.default_rng(5)
    M = rng.standard_normal((12, 12))
    Ms = ScaledM(M, 2.0 ** rng.integers(-3, 3, 12), 4.0)
    v = np.zeros(12)
    v[3:8] = rng.standard_normal(5)
    full = Ms.matvec(v)
    np.testing.assert_allclose(Ms.matvec(v, slice(3, 8)), full, rtol=1e-14)
    np.testing.assert_allclose(Ms.matvec(v, slice(3, 8), rows=True), full[3:8], rtol=1e-14)
    rows, cols = np.array([1, 4, 9]), np.array([0, 4, 11])
    np.testing.assert_allclose(Ms.block(rows, cols), Ms.dense()[np.ix_(rows, cols)], rtol=1e-15)


@pytest.mark.parametrize("seed", range(4))
def test_two_stage_crash_gives_the_textbook_answer_on_benchmark_lcps(seed):
    """LCPs of scripts/bench_lemke.py's kind (unique solutions): the cold start solves
    them on the crash basis with no pivot, with the textbook start's z."""
    for m, mu in ((60, 0.3), (150, 0.3), (100, 1.0)):
        M, q = strip_contact_lcp(m, mu=mu, seed=seed)
        res = lemke(M, q)
        assert_solution(M, q, res)
        assert res.warm_start == "crash" and res.pivots == 0
        cold = lemke(M, q, crash=False)
        np.testing.assert_array_equal(res.basis, cold.basis)
        np.testing.assert_allclose(res.z, cold.z, rtol=0, atol=1e-12 * np.abs(cold.z).max())


@pytest.mark.parametrize("seed", range(3))
def test_crash_result_on_random_and_hard_lcps(seed):
    """The guess may be wrong (Lemke then pivots from it), the answer never is."""
    rng = np.random.default_rng(40 + seed)
    cases = [random_contact_lcp(30, rng), (p_matrix(25, rng), rng.standard_normal(25)),
             near_duplicate_lcp(seed, "matern", "parabolic")]
    for k, (M, q) in enumerate(cases):
        res, cold = lemke(M, q), lemke(M, q, crash=False)
        assert res.ok and cold.ok
        if k < 2:  # unique solutions
            scale = 1.0 + np.abs(cold.z).max()
            np.testing.assert_allclose(res.z, cold.z, rtol=0, atol=1e-8 * scale)
        else:  # contacts 1e-5 apart: the split between twin contacts is not determined,
            # the gaps are
            np.testing.assert_allclose(res.w, cold.w, rtol=0, atol=1e-6 * np.abs(q).max())


def test_crash_basis_returns_the_answer_in_its_scaled_units():
    M, q = strip_contact_lcp(80, seed=6)
    Ms, qs, zfac = diagonal_scaling(M, q)
    B, iterations, zt = crash_basis(Ms, qs)
    cold = lemke(M, q, crash=False)
    assert zt is not None and 1 < iterations < 30
    np.testing.assert_array_equal(B, cold.basis)
    np.testing.assert_allclose(zt * zfac, cold.z, rtol=0, atol=1e-12 * cold.z.max())


def _psd_without_solution():
    """M = g g^T (rank 1) and q with no solution (M z >= -q needs g.z > 0 and g.z < 0), on
    which block pivoting converges to a numerically singular block (found among
    tests/test_lemke.py's random PSD cases)."""
    g = np.array([1.27556525, -1.37763275])
    return np.outer(g, g), np.array([-2.31944502, -0.57371571])


def test_a_converged_crash_on_a_singular_block_leaves_the_solve_to_lemke(monkeypatch):
    """z on the singular block is about 1e16 and passes the relative check: the growth
    test hands it back, and Lemke ends on a secondary ray. Without the test it would be
    reported solved. (The second iteration is forced through the bordered system, where
    the pivot test of the small Schur block does not see the singularity.)"""
    crash = importlib.import_module("app.lcp.crash")
    monkeypatch.setattr(crash._BlockSolver, "_refactor_is_cheaper", lambda *a: False)
    M, q = _psd_without_solution()
    Ms, qs, _ = diagonal_scaling(M, q)
    B, _, zt = crash_basis(Ms, qs)
    assert B.any() and zt is None
    assert lemke(M, q).status == "secondary ray"
    monkeypatch.setattr(importlib.import_module("app.lcp.crash"), "GROWTH_MAX", np.inf)
    wrong = lemke(M, q)
    assert wrong.ok and np.abs(wrong.z).max() > 1e10


def _greedy_twins(s: np.ndarray) -> np.ndarray:
    """twins_from_probe with the pairing loop of its first version (the reference)."""
    n = s.shape[1]
    twin = np.full(n, -1, dtype=np.int64)
    order = np.argsort(np.abs(s[0]), kind="stable")
    so = s[:, order]
    close = ((np.abs(so[:, 1:] + so[:, :-1]) <= 1e-12 * np.abs(so[:, 1:])).all(axis=0)
             & (so[0, 1:] != 0.0) & (np.sign(so[0, 1:]) != np.sign(so[0, :-1])))
    for k in np.flatnonzero(close):
        i, j = int(order[k]), int(order[k + 1])
        if twin[i] < 0 and twin[j] < 0:
            twin[i], twin[j] = j, i
    return twin


def test_vectorized_twin_pairing_equals_the_greedy_loop_on_chains():
    rng = np.random.default_rng(3)
    # runs of 2 to 5 columns with sums of one size and alternating signs: chains of close
    # neighbours, where the greedy pairing keeps every other pair
    sizes = rng.permutation(np.arange(1.0, 41.0))
    cols = [a * np.array([1.0, -1.0, 1.0, -1.0, 1.0][:k]) for a, k in
            zip(sizes, rng.integers(1, 6, sizes.size), strict=True)]
    s = np.concatenate(cols)[None, :]
    s = s[:, rng.permutation(s.shape[1])]
    twin = twins_from_probe(s)
    np.testing.assert_array_equal(twin, _greedy_twins(s))
    paired = twin >= 0
    np.testing.assert_array_equal(twin[twin[paired]], np.flatnonzero(paired))
    np.testing.assert_array_equal(s[0, paired], -s[0, twin[paired]])


def test_gather_equals_fancy_indexing_for_any_layout():
    rng = np.random.default_rng(5)
    M = rng.standard_normal((30, 40))
    rows, cols = rng.choice(30, 12, replace=False), rng.choice(40, 7, replace=False)
    for A in (M, np.asfortranarray(M), M[:, ::2]):
        c = cols[cols < A.shape[1]]
        out = gather(A, rows, c)
        np.testing.assert_array_equal(out, A[np.ix_(rows, c)])
        assert out.flags.c_contiguous


def test_twin_product_on_the_twin_range_equals_the_block_product():
    M, q = strip_contact_lcp(40, seed=1)
    Ms, _, _ = diagonal_scaling(M, q)
    twin = find_twins(Ms)
    tpart = _twin_range(twin)
    assert tpart == slice(40, 120)
    assert _twin_range(np.full(4, -1)) is None
    assert _twin_range(np.array([2, -1, 0, -1])) is None  # twins not one range
    product = _TwinProduct(Ms, twin, tpart)
    assert product.runs == [slice(40, 80)]
    rng = np.random.default_rng(2)
    z = np.zeros(q.size)
    z[tpart] = np.where(rng.random(80) < 0.5, rng.random(80), 0.0)
    ref = Ms.matvec(z)[tpart]
    np.testing.assert_allclose(product(z), ref, rtol=0, atol=1e-13 * np.abs(ref).max())


@pytest.mark.parametrize("seed", range(3))
def test_twin_stage_solves_the_slips_under_fixed_normal_pressures(seed):
    """The set the twins' stage returns solves the LCP over the twin indices with
    q' = M~ z~ + q~ of a fixed normal part (z~ = 0 on the twins), checked directly."""
    m = 60
    M, q = strip_contact_lcp(m, seed=seed)
    Ms, qs, _ = diagonal_scaling(M, q)
    twin = find_twins(Ms)
    tpart = _twin_range(twin)
    z = np.zeros(q.size)
    z[:m] = np.maximum(-qs[:m], 0.0)  # some normal pressures
    w = Ms.matvec(z) + qs
    S, iterations, _ = _twin_stage(Ms, w, twin, tpart, 30)
    assert S is not None and not S[:m].any() and 1 <= iterations < 30
    assert not (S & S[twin.clip(0)] & (twin >= 0)).any()  # never both slips of a pair
    Md = Ms.dense()[tpart, tpart]
    idx = np.flatnonzero(S[tpart])
    x = np.zeros(2 * m)
    x[idx] = np.linalg.solve(Md[np.ix_(idx, idx)], -w[tpart][idx])
    wt = Md @ x + w[tpart]
    assert (x >= -1e-12).all() and (wt >= -1e-12).all()


def test_check_lower_bound_keeps_the_verdict_and_bounds_the_residual():
    """Rows settled by the lower bound |q_i| + |w_i - q_i| of their row size: the verdict
    is that of the exact row sizes and the residual at least the exact one."""
    for seed in range(4):
        M, q = strip_contact_lcp(50, seed=seed)
        z = lemke(M, q).z
        for zz in (z, z * (1 + 1e-15), z * (1 + 1e-6)):
            new, old = LM._check(M, q, zz, 1e-9), _old_check(M, q, zz, 1e-9)
            assert new[1] == old[1]
            assert old[3] * (1 - 1e-12) <= new[3] <= max(old[3], LM._SETTLE_REL) * (1 + 1e-12)
