"""The one recovery step of `lemke` (app/lcp/recovery.py) and the balancing it applies
(app/lcp/balance.py): LCPs whose rows or columns are in very different units."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

from app.lcp import exact, lemke
from app.lcp.balance import balance, imbalanced
from app.lcp.cases import p_pd
from app.lcp.recovery import recover
from app.lcp.result import LCPResult

LM = importlib.import_module("app.lcp.lemke")


def row_scaled_p(seed: int, n: int = 40):
    """A P-matrix LCP with its rows scaled by 1e-8..1e8 (the same solutions)."""
    rng = np.random.default_rng(seed)
    M, q = p_pd(n, rng), rng.standard_normal(n)
    R = 10.0 ** rng.uniform(-8, 8, n)
    return M, q, R[:, None] * M, R * q


@pytest.mark.parametrize("crash", [True, False])
def test_row_scaled_p_matrices_are_solved(crash):
    """Lemke's symmetric scaling cannot balance R M: before the balanced LCP of the
    recovery, 10 of these 20 ended on a secondary ray or "inaccurate" (crash) and 20 of 20
    from the textbook start."""
    for seed in range(20):
        M, q, Mr, qr = row_scaled_p(seed)
        ref = lemke(M, q)
        res = lemke(Mr, qr, crash=crash)
        assert res.ok, (seed, res.message)
        np.testing.assert_allclose(res.z, ref.z, rtol=1e-7, atol=1e-9 * np.abs(ref.z).max())
        np.testing.assert_allclose(res.w, Mr @ res.z + qr, rtol=0,
                                   atol=1e-12 * (np.abs(qr) + np.abs(Mr) @ res.z).max())


def test_symmetrically_scaled_p_matrix_from_the_textbook_start():
    """D M D with D in 1e-8..1e8 (z = z0 / D): Lemke's scaling takes the row maximum for a
    diagonal entry below 1e-6 of it, which does not undo D; the textbook start ended on a
    secondary ray (scripts/check_lcp.py, round 3)."""
    rng = np.random.default_rng(5)
    bad = 0
    for _ in range(30):
        n = 10
        M, q = p_pd(n, rng), rng.standard_normal(n)
        D = 10.0 ** rng.uniform(-8, 8, n)
        z0 = exact.solutions(M, q)[0]
        res = lemke(D[:, None] * M * D, D * q, crash=False)
        assert res.ok, res.message
        bad += "balanced" in res.message
        np.testing.assert_allclose(res.z * D, z0, rtol=1e-6, atol=1e-9 * np.abs(z0).max())
    assert bad > 0  # some needed the balanced LCP


def test_balance_leaves_a_balanced_lcp_alone_and_keeps_symmetry():
    rng = np.random.default_rng(0)
    M = p_pd(30, rng)
    assert not imbalanced(M) and balance(M) is None
    D = 2.0 ** rng.integers(-26, 27, 30)  # (powers of two: D S D stays symmetric)
    S = M + M.T
    r, c = balance(D[:, None] * S * D)
    np.testing.assert_array_equal(r, c)
    B = r[:, None] * (D[:, None] * S * D) * c
    np.testing.assert_array_equal(B, B.T)
    mx = np.abs(B).max(axis=1)
    assert mx.min() >= 0.25 and mx.max() <= 4.0


def test_a_wrong_size_basis_is_an_error_when_q_is_nonnegative():
    """It was ignored (z = 0 returned) when q >= 0, an error only when some q_i < 0."""
    with pytest.raises(ValueError, match="basis must have shape"):
        lemke(np.eye(3), np.ones(3), basis=np.ones(2, dtype=bool))


def _result(status, pivots, basis):
    n = basis.size
    return LCPResult(np.zeros(n), np.zeros(n), pivots, status, 0.0, basis, status)


def test_recovery_order_and_one_budget():
    """After 'inaccurate': up to 3 restarts from the final basis (each from the last one's
    basis), then the balanced LCP only when imbalanced, then the QP repair for a symmetric
    M; the pivots of every attempt count, and the first result stands when all fail."""
    calls = []
    B = np.array([True, False])

    def run(M, q, budget, basis, cold, crash):
        calls.append((None if basis is None else basis.tolist(), cold, crash, budget))
        return _result("secondary ray", 5, B)

    def check(M, q, z):
        raise AssertionError("no answer to check")

    M = np.array([[2.0, 1.0], [1.0, 2.0]])
    first = _result("inaccurate", 7, B)
    out = recover(run, check, M, -np.ones(2), first, 100, True)
    assert out is first and out.status == "inaccurate"
    assert calls[:3] == [([True, False], False, True, 93), ([True, False], False, True, 88),
                         ([True, False], False, True, 83)]
    assert len(calls) == 4 and calls[3][1:3] == (False, False)  # the QP warm start
    assert out.pivots == 7 + 4 * 5
    calls.clear()
    out = recover(run, check, M, -np.ones(2), _result("secondary ray", 7, B), 100, True)
    assert [c[1:3] for c in calls] == [(False, False)]  # no restart after a ray


def test_an_answer_of_the_balanced_lcp_is_checked_in_the_callers_units(monkeypatch):
    """The balanced LCP's answer is mapped back (z = C z') and checked on the caller's M and
    q; one that fails there is not returned as solved."""
    M, q, Mr, qr = row_scaled_p(1)

    def wrong_unbalanced(check, M, q, res, c):
        return None

    monkeypatch.setattr("app.lcp.recovery._unbalanced", wrong_unbalanced)
    monkeypatch.setattr("app.lcp.recovery.is_symmetric", lambda M: False)
    assert not lemke(Mr, qr, crash=False).ok


def test_unbalanced_maps_z_back_and_rejects_an_answer_wrong_in_the_callers_units():
    """`_unbalanced`: z = C z' of the balanced LCP passes the check on the caller's M, q;
    the same z' without C (an answer right only in the balanced units) does not."""
    from app.lcp.recovery import _unbalanced

    M, q, Mr, qr = row_scaled_p(1)
    r, c = balance(Mr)
    assert not np.allclose(c, 1.0)
    solved = lemke(r[:, None] * Mr * c, r * qr)
    assert solved.ok

    def check(Mc, qc, z):
        return LM._check(Mc, qc, z, LM.DEFAULT_TOL)

    out = _unbalanced(check, Mr, qr, solved, c)
    assert out is not None and out.ok
    np.testing.assert_allclose(out.z, lemke(M, q).z, rtol=1e-7, atol=1e-9 * np.abs(out.z).max())
    assert _unbalanced(check, Mr, qr, solved, np.ones_like(c)) is None
