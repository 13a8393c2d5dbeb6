"""The crash's last product as the final check's (app/lcp/check_product.py) and the Cholesky
factors of unscaled blocks (app/lcp/crash.py `_factor` with d): the check stays the same
check, a wrong answer is still rejected, and the factors are the scaled ones to the bit."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from app.lcp import lemke
from app.lcp.cases import strip_contact_lcp
from app.lcp.check_product import CheckProduct
from app.lcp.crash import _factor, crash_basis
from app.lcp.scaling import diagonal_scaling, gather
from tests.test_lemke import assert_solution, p_matrix

LM = importlib.import_module("app.lcp.lemke")
CP = importlib.import_module("app.lcp.check_product")


def test_check_product_is_the_check_of_that_z_and_of_no_other():
    M, q = strip_contact_lcp(40, seed=1)
    Ms, qs, zfac = diagonal_scaling(M, q)
    rng = np.random.default_rng(0)
    zt = np.where(rng.random(q.size) < 0.4, rng.random(q.size), 0.0)
    exact = CheckProduct(M, q, Ms.D, zfac)
    wt = exact(zt)
    np.testing.assert_allclose(wt, Ms.matvec(zt) + qs, rtol=0, atol=1e-14 * np.abs(wt).max())
    z = np.maximum(zt * zfac, 0.0)  # the z of lemke's finish
    w = exact.w_for(z)
    assert w is not None and exact.products == 1
    ref = LM._check(M, q, z, 1e-9)
    new = LM._check(M, q, z, 1e-9, w)
    np.testing.assert_array_equal(new[0], ref[0])
    assert new[1:] == ref[1:]
    other = z.copy()
    other[np.flatnonzero(z)[0]] *= 1.0 + 1e-15
    assert exact.w_for(other) is None  # another z: the check forms its own product
    assert exact(-zt - 1.0) is None and exact.products == 1  # z~ < 0: not the check's z


@pytest.mark.parametrize("seed", range(3))
def test_the_reused_product_still_rejects_a_wrong_answer(seed, monkeypatch):
    """The crash is made to believe its first round ended (every w~ reported >= 0) on a
    wrong set: the kept product is the true M z + q of that z, so the check rejects it,
    and lemke goes on to the right answer (Lemke from the crash basis, or the LU). (No
    twins: the crash's product is a plain one, so the check's serves from the first
    round.)"""
    rng = np.random.default_rng(10 + seed)
    M, q = p_matrix(30, rng), rng.standard_normal(30)
    call = CheckProduct.__call__

    def fooled(self, zt):
        wt = call(self, zt)
        return None if wt is None else np.abs(wt)

    monkeypatch.setattr(CP.CheckProduct, "__call__", fooled)
    Ms, qs, zfac = diagonal_scaling(M, q)
    exact = CheckProduct(M, q, Ms.D, zfac)
    B, _, zt = crash_basis(Ms, qs, exact=exact)
    assert zt is not None and exact.products == 1  # ended after its first round
    z = np.maximum(zt * zfac, 0.0)
    w = exact.w_for(z)
    assert w is not None and not LM._check(M, q, z, 1e-9, w)[1]  # a wrong answer
    res = lemke(M, q)
    assert_solution(M, q, res)
    assert res.warm_start != "crash"
    cold = lemke(M, q, crash=False)
    np.testing.assert_allclose(res.z, cold.z, rtol=0, atol=1e-8 * (1 + np.abs(cold.z).max()))


def test_the_cold_start_checks_with_the_crash_product_on_benchmark_lcps(monkeypatch):
    """One pass over M for the check and the crash's last round, not two; the answer is
    the crash's solve on the final set (no correction after the checked product), within
    round-off of the textbook start's."""
    passes = []
    init = CheckProduct.__init__

    def counted(self, *args):
        init(self, *args)
        passes.append(self)

    monkeypatch.setattr(CP.CheckProduct, "__init__", counted)
    checks = []
    check = LM._check
    monkeypatch.setattr(LM, "_check", lambda M, q, z, tol, w=None, cache=None:
                        checks.append(w is not None) or check(M, q, z, tol, w, cache))
    for m, seed in ((100, 0), (300, 1)):
        M, q = strip_contact_lcp(m, seed=seed)
        res = lemke(M, q)
        assert_solution(M, q, res)
        assert res.warm_start == "crash" and passes[-1].products == 1 and checks[-1]
        cold = lemke(M, q, crash=False)
        np.testing.assert_array_equal(res.basis, cold.basis)
        np.testing.assert_allclose(res.z, cold.z, rtol=0, atol=1e-13 * cold.z.max())


def test_cholesky_of_the_unscaled_block_is_the_scaled_one_to_the_bit():
    M, q = strip_contact_lcp(60, seed=4)
    Ms, _, _ = diagonal_scaling(M, q)
    rng = np.random.default_rng(1)
    for Z in (np.flatnonzero(q[:60] < 0), np.sort(rng.choice(np.arange(60, 120), 40, False))):
        d = Ms.D[Z]
        scaled = _factor(Ms.sub(Z), cholesky=True)
        unscaled = _factor(gather(M, Z, Z), cholesky=True, d=d)
        assert scaled.cholesky and unscaled.cholesky
        b = rng.standard_normal(Z.size)
        B = np.asfortranarray(rng.standard_normal((Z.size, 3)))
        np.testing.assert_array_equal(unscaled.solve(b), scaled.solve(b))
        np.testing.assert_array_equal(unscaled.solve(B.copy(order="F"), overwrite=True),
                                      scaled.solve(B.copy(order="F"), overwrite=True))


def test_an_unscaled_block_that_is_not_positive_definite_gets_the_scaled_lu():
    rng = np.random.default_rng(2)
    G = rng.standard_normal((30, 30))
    A = G + G.T  # symmetric, indefinite: Cholesky fails, the LU factors the scaled block
    d = 2.0 ** rng.integers(-4, 4, 30)
    As = d[:, None] * A * d
    f = _factor(A.copy(), cholesky=True, d=d)
    ref = _factor(As.copy(), cholesky=True)
    assert not f.cholesky and not ref.cholesky
    b = rng.standard_normal(30)
    np.testing.assert_array_equal(f.solve(b), ref.solve(b))
    np.testing.assert_allclose(As @ f.solve(b), b, rtol=0, atol=1e-9 * np.abs(b).max())


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_entry_outside_the_sampled_rows_is_still_rejected(bad):
    """The cold start reads PROBE_ROWS rows for the twins; M is checked to be finite by
    the final check's product (or the full probe): every position, also with q >= 0."""
    M, q = strip_contact_lcp(150, seed=2)  # n = 450 > 2 PROBE_ROWS: the sampled probe
    assert LM._validate(M, q, sample=True)[3]
    crash = importlib.import_module("app.lcp.crash")
    outside = np.setdiff1d(np.arange(q.size), np.arange(q.size)[crash.probe_rows(q.size)])
    res = lemke(M, q)
    zero = np.flatnonzero(res.z == 0)  # a column that the answer's z does not use
    for i, j in ((outside[0], zero[0]), (outside[-1], outside[-1]), (outside[5], 3)):
        B = M.copy()
        B[i, j] = bad
        with pytest.raises(ValueError, match="finite"):
            lemke(B, q)
        with pytest.raises(ValueError, match="finite"):
            lemke(B, np.abs(q))  # q >= 0: z = 0 without a crash, still validated
    F = np.asfortranarray(M)  # not C-ordered: the full probe at once
    assert not LM._validate(F, q, sample=True)[3]


def test_twins_of_a_sampled_probe_are_verified_on_their_own_rows():
    """Columns that are negatives of each other except on the diagonal (a regularized
    slip pair) look like twins to rows sampled elsewhere; the check on rows i and j
    drops them, and true twins stay."""
    crash = importlib.import_module("app.lcp.crash")
    M, q = strip_contact_lcp(150, seed=3)
    m = 150
    D = LM._diagonal_D(M)
    full = crash.twins_from_probe(crash.column_probe(M, D))
    sampled = crash.verified_twins(M, crash.twins_from_probe(crash.sampled_probe(M, D)))
    np.testing.assert_array_equal(sampled, full)
    k = np.arange(m, 2 * m)
    R = M.copy()
    R[k, k] += 1e-3  # M[f, f] = H + eps I, M[b, b] = H + eps I: no longer twins
    R[k + m, k + m] += 1e-3
    raw = crash.twins_from_probe(crash.sampled_probe(R, D))
    rows = np.arange(3 * m)[crash.probe_rows(3 * m)]
    hidden = np.setdiff1d(k, np.concatenate([rows, rows - m]))  # both rows unsampled
    assert (raw[hidden] >= 0).all()  # taken for twins by the sampled rows
    assert (crash.verified_twins(R, raw)[k] < 0).all()
    res = lemke(R, q)
    assert_solution(R, q, res)
