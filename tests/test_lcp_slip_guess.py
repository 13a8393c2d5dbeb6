"""The twins' stage's first guess (app/lcp/slip_guess.py): a twin-free set on the twin
range, the trial guess after one sweep, closer to the stage's answer than the trial guess
after more, the fallbacks; and the crash with it: the same answers as with the trial
guess, one factorization of the slip block fewer on the benchmark LCP."""

from __future__ import annotations

import numpy as np
import pytest

import app.lcp.crash as crash
import app.lcp.slip_guess as sg
from app.lcp import lemke
from app.lcp.cases import random_contact_lcp, strip_contact_lcp
from app.lcp.crash import _FEAS_REL, _twin_range, _twin_stage, _untwin, find_twins
from app.lcp.scaling import ScaledM, diagonal_scaling
from app.lcp.slip_guess import slip_guess


def _stage_lcp(M, q):
    """(Ms, w, twin, tpart) of a twins' stage: the normal pressures that close the
    penetrations alone (z~ = -q~ on the normals), slips 0, w = M~ z~ + q~."""
    Ms, qs, _ = diagonal_scaling(M, q)
    twin = find_twins(Ms)
    tpart = _twin_range(twin)
    m = tpart.start
    z = np.zeros(q.size)
    z[:m] = np.maximum(-qs[:m], 0.0)
    return Ms, Ms.matvec(z) + qs, twin, tpart


def _trial(w, twin):
    none = np.zeros(w.size, dtype=bool)
    return _untwin(w < -_FEAS_REL, none, w, twin)


@pytest.mark.parametrize("seed", range(4))
def test_guess_is_twin_free_on_the_range_and_one_sweep_is_the_trial_guess(seed):
    M, q = strip_contact_lcp(60, seed=seed)
    Ms, w, twin, tpart = _stage_lcp(M, q)
    G = slip_guess(Ms, w, twin, tpart)
    assert not G[: tpart.start].any() and not G[tpart.stop:].any()
    assert not (G & G[twin.clip(0)] & (twin >= 0)).any()  # never both slips of a pair
    np.testing.assert_array_equal(slip_guess(Ms, w, twin, tpart, sweeps=1), _trial(w, twin))


@pytest.mark.parametrize("seed", range(3))
def test_guess_is_closer_to_the_stage_answer_than_the_trial_guess(seed):
    """On the strip LCPs (where Jacobi converges) and on a dense random compliance (where
    it turns back after a few sweeps and the last contracting sweep's set is kept)."""
    rng = np.random.default_rng(seed)
    for M, q in (strip_contact_lcp(150, seed=seed), random_contact_lcp(120, rng)):
        Ms, w, twin, tpart = _stage_lcp(M, q)
        S, _, _ = _twin_stage(Ms, w, twin, tpart, 30)  # the stage's exact set
        assert S is not None
        off_guess = int((slip_guess(Ms, w, twin, tpart) != S).sum())
        off_trial = int((_trial(w, twin) != S).sum())
        assert off_guess < off_trial


def test_fallbacks_to_the_trial_guess():
    M, q = strip_contact_lcp(20, seed=1)
    Ms, w, twin, tpart = _stage_lcp(M, q)
    assert slip_guess(Ms, w, twin, tpart, sweeps=0) is None
    broken = twin.copy()
    broken[tpart.start] = 0  # a twin outside the range
    assert slip_guess(Ms, w, broken, tpart) is None
    Mn = M.copy()
    Mn[tpart.start, tpart.start] = -1.0  # a diagonal entry of H not positive
    assert slip_guess(ScaledM(Mn, Ms.D, Ms.mu), w, twin, tpart) is None


def test_jacobi_that_turns_back_keeps_the_last_contracting_sweep():
    """H with off-diagonal 0.9 (Jacobi's iteration matrix has eigenvalue -1.8): the first
    sweep sets every x_k = 1, the second takes them back to 0 (a step as long as the
    first): the guess stops there and keeps the first sweep's set."""
    k = 3
    H = np.full((k, k), 0.9) + 0.1 * np.eye(k)
    M = np.block([[H, -H], [-H, H]])
    twin = np.r_[np.arange(k, 2 * k), np.arange(k)]
    qt = np.r_[-np.ones(k), np.full(k, 5.0)]
    Ms = ScaledM(M, np.ones(2 * k), 1.0)
    G = slip_guess(Ms, qt, twin, slice(0, 2 * k), sweeps=50)
    assert G is not None and not (G[:k] & G[k:]).any()
    assert G[:k].all()
    np.testing.assert_array_equal(G, slip_guess(Ms, qt, twin, slice(0, 2 * k), sweeps=1))


def _stage_factorizations(monkeypatch, M, q) -> tuple[object, int]:
    """lemke's result and the factorizations of the twins' stage's block solver."""
    counts = []

    def stage(*args):
        out = _twin_stage(*args)
        counts.append(out[2].factorizations)
        return out

    monkeypatch.setattr(crash, "_twin_stage", stage)
    res = lemke(M, q)
    monkeypatch.setattr(crash, "_twin_stage", _twin_stage)
    assert len(counts) == 1
    return res, counts[0]


@pytest.mark.parametrize("m, mu, seed", [(500, 0.3, 0), (150, 0.3, 1), (100, 1.0, 2)])
def test_guess_saves_a_factorization_with_the_same_answer(monkeypatch, m, mu, seed):
    """The benchmark LCP (n = 1500, scripts/bench_lemke.py) and smaller ones: the slip
    block is factorized once instead of two or three times, the answer is the trial
    guess's (same basis, crash start, no pivot, z to round-off) and the textbook start's
    basis."""
    M, q = strip_contact_lcp(m, mu=mu, seed=seed)
    res, f_guess = _stage_factorizations(monkeypatch, M, q)
    monkeypatch.setattr(sg, "SWEEPS", 0)
    trial, f_trial = _stage_factorizations(monkeypatch, M, q)
    assert f_guess == 1 < f_trial
    if m == 500:  # the benchmark LCP: 2 factorizations of the slip block with the trial
        assert f_trial == 2
    for r in (res, trial):
        assert r.status == "solved" and r.warm_start == "crash" and r.pivots == 0
    np.testing.assert_array_equal(res.basis, trial.basis)
    np.testing.assert_allclose(res.z, trial.z, rtol=0, atol=1e-13 * np.abs(trial.z).max())
    if m <= 150:
        np.testing.assert_array_equal(res.basis, lemke(M, q, crash=False).basis)
