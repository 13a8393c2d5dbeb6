"""The LCP matrix's cache (app/lcp/matrix_cache.py): a load step's debonding rounds and the
load steps change only q, so what `lemke` derives from M alone is formed once per run (the
same bits as without the cache), and a warm start is solved on a kept factorization of a
nearby basis block (the same answer to round-off)."""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import app.lcp.crash as crash
import app.lcp.scaling as scaling
from app.interface.coulomb import ContactLCP
from app.interface.steps import InterfaceHistory, solve_step
from app.lcp.lemke import MatrixCache, lemke

lemke_module = importlib.import_module("app.lcp.lemke")  # (app.lcp.lemke is the function)
TOL = 1e-12


def _bonded_strip(m: int = 24) -> tuple[ContactLCP, InterfaceHistory, np.ndarray, np.ndarray]:
    """m frictional bonded pairs in a row, each coupled to its neighbours, pulled open at
    one end and sheared: the bond unzips from that end over several debonding rounds."""
    k = np.eye(m) + 0.3 * (np.eye(m, k=1) + np.eye(m, k=-1))
    c = np.block([[k, 0.1 * np.eye(m)], [0.1 * np.eye(m), 2.0 * k]])
    lcp = ContactLCP(c, np.full(m, 0.3), np.ones(m, dtype=bool), None, None)
    hist = InterfaceHistory(a=np.full(m, 0.5), c=np.full(m, 0.4), bonded=np.ones(m, dtype=bool),
                            tau_prev=np.zeros(m), debonded_step=np.zeros(m, dtype=np.int64))
    x = np.linspace(0.0, 1.0, m)
    return lcp, hist, 1.2 * (1.0 - x) ** 2 - 0.05, 0.4 * (1.0 - x)


def _counting(monkeypatch, module, name: str) -> list[int]:
    """Count the calls of module.name (still calling it)."""
    calls = [0]
    real = getattr(module, name)

    def counted(*args, **kw):
        calls[0] += 1
        return real(*args, **kw)

    monkeypatch.setattr(module, name, counted)
    return calls


def test_debonding_rounds_read_M_for_its_probe_and_scaling_once(monkeypatch):
    """Each round re-solved with the same M read it whole for the column probe (twice: the
    finiteness check and the warm crash's twins) and for the scaling (and the final
    check's max |D M D|): 0.36 s of 1.17 s in 26 solves of a 976-unknown LCP under
    cProfile (multibody.toml --refine 2, step 4's debonding rounds)."""
    probes = _counting(monkeypatch, lemke_module, "column_probe")
    twins = _counting(monkeypatch, crash, "column_probe")
    scalings = _counting(monkeypatch, scaling, "matrix_scaling")
    monkeypatch.setattr(lemke_module, "matrix_scaling", scaling.matrix_scaling)
    lcp, hist, gap_free, tau_free = _bonded_strip()
    res = solve_step(lcp, hist, 1, gap_free, tau_free, np.full(lcp.m, 0.3), np.zeros(0), TOL,
                     TOL)
    assert res.status == "solved" and res.iterations >= 4
    assert 0 < hist.debonded_step.astype(bool).sum() < lcp.m
    assert probes[0] == 1 and twins[0] <= 1 and scalings[0] == 1


def test_debonding_rounds_factorize_the_warm_start_block_once(monkeypatch):
    """Each round factorized the block of its warm-start basis twice (to try it, and again
    for the block pivoting from it): 2 x 7 factorizations of a 59 x 59 block here, and on
    multibody.toml --refine 2 (step 4, 25 rounds, blocks of about 370) most of the time
    of the lcp phase. Now the rounds border the indices that changed on the one block the
    cache's block solver factorized."""
    sizes = []
    for module, name in ((crash, "_factor"), (lemke_module, "_lu_or_none")):
        real = getattr(module, name)

        def counted(A, *args, _real=real, **kw):
            sizes.append(A.shape[0])
            return _real(A, *args, **kw)

        monkeypatch.setattr(module, name, counted)
    lcp, hist, gap_free, tau_free = _bonded_strip(60)
    res = solve_step(lcp, hist, 1, gap_free, tau_free, np.full(lcp.m, 0.3), np.zeros(0), TOL,
                     TOL)
    assert res.status == "solved" and res.iterations >= 6 and res.pivots == 0
    assert sum(k > 30 for k in sizes) <= 3  # the first (cold) solve's, and the kept one


def test_a_step_with_the_cache_gives_the_answer_without_it(monkeypatch):
    lcp, hist, gap_free, tau_free = _bonded_strip()
    res = solve_step(lcp, hist, 1, gap_free, tau_free, np.full(lcp.m, 0.3), np.zeros(0), TOL,
                     TOL)
    lcp2, hist2, _, _ = _bonded_strip()
    real = lcp2.solver
    lcp2.solver = lambda M, q, cache=None, **kw: real(M, q, **kw)  # no cache
    res2 = solve_step(lcp2, hist2, 1, gap_free, tau_free, np.full(lcp.m, 0.3), np.zeros(0),
                      TOL, TOL)
    assert res.iterations == res2.iterations and res.pivots == res2.pivots
    assert np.array_equal(res.solution.basis, res2.solution.basis)
    for name in ("p", "q", "gap", "tau", "slip_plus", "slip_minus"):
        a, b = getattr(res.solution, name), getattr(res2.solution, name)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max(), err_msg=name)
    assert np.array_equal(res.state, res2.state)
    assert np.array_equal(res.debonded_step, res2.debonded_step)
    assert sum(lcp.cache.hits.values()) > 0


def test_lemke_with_the_cache_returns_what_it_returns_without():
    """A sequence of q for one M, each warm started from the last basis: the same basis,
    pivots and message with the cache as without, also on the lemke_tableau core, and z
    and w to round-off; from the crash guess (no warm start) the same bits."""
    rng = np.random.default_rng(3)
    n = 60
    a = rng.standard_normal((n, n))
    s = 0.5 * rng.standard_normal((n, n))
    M = a @ a.T / n + 0.1 * np.eye(n) + (s - s.T)  # positive definite, not symmetric
    cache = MatrixCache(M)
    for solver in (lemke, lemke_module.lemke_tableau):
        basis = None
        for k in range(6):
            q = rng.standard_normal(n) - 0.2 * k
            r1 = solver(M, q, basis=basis, cache=cache)
            r2 = solver(M.copy(), q, basis=basis)
            assert r1.status == r2.status == "solved"
            assert np.array_equal(r1.basis, r2.basis)
            same = np.array_equal if basis is None else (
                lambda a, b: np.allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max()))
            assert same(r1.z, r2.z) and same(r1.w, r2.w)
            assert (r1.pivots, r1.message, r1.warm_start) == (r2.pivots, r2.message,
                                                             r2.warm_start)
            basis = r1.basis
    assert cache.misses["scaling"] == 1 and cache.hits["scaling"] > 0


def test_a_cache_serves_only_its_own_matrix_which_it_makes_read_only():
    M = np.eye(3) + 0.1
    cache = MatrixCache(M)
    with pytest.raises(ValueError, match="read-only"):
        M[0, 0] = 2.0
    with pytest.raises(ValueError, match="another matrix"):
        lemke(M.copy(), -np.ones(3), cache=cache)
    with pytest.raises(ValueError, match="owns its data"):
        MatrixCache(np.eye(4)[:3, :3])
    lcp = ContactLCP(np.diag([2e-3, 5e-3]), np.full(1, 0.3), np.ones(1, bool))
    assert not lcp.M_scaled.flags.writeable and lcp.cache.M is lcp.M_scaled


def test_a_solve_forms_the_free_motion_once(monkeypatch):
    """`ContactLCP._free_motion` served the constant vector and again the recovery of q."""
    lcp, hist, gap_free, tau_free = _bonded_strip(6)
    calls = _counting(monkeypatch, lcp, "_free_motion")
    sol = lcp.solve(gap_free, tau_free, hist.tau_prev, hist.a, hist.c, np.full(6, 0.3),
                    np.zeros(0))
    assert sol.status == "solved" and calls[0] == 1


def test_without_the_cache_each_solve_reads_M_afresh():
    """`ContactLCP(cache=False)` (the PETSc option -contact_lcp_cache 0): no cache, the
    matrix stays writable, and the step's answer is the one with the cache to round-off."""
    lcp, hist, gap_free, tau_free = _bonded_strip()
    off = ContactLCP(lcp.c, np.full(lcp.m, 0.3), np.ones(lcp.m, dtype=bool), cache=False)
    assert off.cache is None and off.M_scaled.flags.writeable
    hist2 = _bonded_strip()[1]
    res = solve_step(lcp, hist, 1, gap_free, tau_free, np.full(lcp.m, 0.3), np.zeros(0), TOL,
                     TOL)
    res2 = solve_step(off, hist2, 1, gap_free, tau_free, np.full(lcp.m, 0.3), np.zeros(0),
                      TOL, TOL)
    assert np.array_equal(res.debonded_step, res2.debonded_step)
    np.testing.assert_allclose(res.solution.p, res2.solution.p, rtol=0,
                               atol=1e-12 * np.abs(res2.solution.p).max())


def test_the_z_scale_memo_keeps_a_few_scalings_only():
    """`_z_scale` keeps max |D M D| per scaling D, and D depends on the violating rows of
    the check (`_floor_D`: a round-off diagonal's column is scaled by its largest entry on
    those rows), so a run with many distinct row sets made as many entries of n x 8 bytes
    each (before: 40 here). The memo keeps the most recent few, and gives the same value
    as a fresh computation."""
    rng = np.random.default_rng(3)
    n = 30
    M = rng.standard_normal((n, n))
    cache = MatrixCache(M)
    q, z = np.full(n, -1e6), np.zeros(n)  # |q~| / max |M~| decides: M~ is read
    for _ in range(40):
        D = 1.0 + rng.random(n)
        got = lemke_module._z_scale(M, q, z, np.zeros(0), D, cache)
        assert got == lemke_module._z_scale(M, q, z, np.zeros(0), D, None)
    kept = [key for key in cache._memo if key[0] == "absmax"]
    assert len(kept) == lemke_module._ABSMAX_KEEP  # 40 distinct D: the bound is reached
    assert lemke_module._ABSMAX_KEEP < 40
    assert cache.misses["absmax"] == 40
