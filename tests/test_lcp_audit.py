"""The adversarial LCP checker (app/lcp/exact.py, app/lcp/audit.py, scripts/check_lcp.py):
its reference, its classification (it must be able to fail), and one fixed-seed round."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from app.interface.audit_cases import Case, contact_case
from app.lcp import exact, lemke
from app.lcp.audit import Reference, classify, row_violation
from app.lcp.result import LCPResult
from tests.support import ROOT, mpi_env


def test_exact_enumeration_finds_every_solution():
    M = np.array([[1.0, 2.0], [2.0, 1.0]])  # not P: three solutions for q = (-1, -1)
    sols = exact.solutions(M, np.array([-1.0, -1.0]))
    got = sorted(tuple(np.round(s, 12)) for s in sols)
    np.testing.assert_allclose(got, [(0.0, 1.0), (1 / 3, 1 / 3), (1.0, 0.0)], atol=1e-12)
    assert exact.solutions(-np.eye(2), -np.ones(2)) == []
    assert exact.is_p_matrix(np.array([[1.0, 5.0], [0.0, 1.0]]))
    assert not exact.feasible(np.array([[1.0, -1.0], [-1.0, 1.0]]), -np.ones(2))


def _fake(z, status="solved"):
    def solve(M, q, **kw):
        return LCPResult(np.asarray(z, float), M @ z + q, 1, status, 0.0,
                         np.asarray(z) > 0, status)
    return solve


def test_classification_flags_wrong_missed_hang_and_exceptions():
    M, q = np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-1.0, -1.0])
    case = Case("p", M, q, "P")
    ref = Reference(case)
    assert classify(case, _fake([1 / 3, 1 / 3]), ref)["outcome"] == "ok"
    assert classify(case, _fake([0.5, 0.0]), ref)["outcome"] == "wrong"
    assert classify(case, _fake([0.0, 0.0], "secondary ray"), ref)["outcome"] == "missed"
    assert classify(case, _fake([0.0, 0.0], "pivot limit"), ref)["outcome"] == "hang"

    def boom(M, q, **kw):
        raise IndexError("x")

    assert classify(case, boom, ref)["outcome"] == "exception"
    bad = Case("p", M, q, "P", {"basis": np.ones(3, bool)}, error=True)
    assert classify(bad, lemke, ref)["outcome"] == "ok"
    assert classify(bad, _fake([1 / 3, 1 / 3]), ref)["outcome"] == "exception"
    infeasible = Case("i", -np.eye(2), -np.ones(2), "none", expect="infeasible")
    iref = Reference(infeasible)
    assert classify(infeasible, _fake([0.0, 0.0]), iref)["outcome"] == "wrong"
    assert classify(infeasible, lemke, iref)["outcome"] == "ok"


def test_round_off_on_a_degenerate_row_is_not_a_violation():
    M = np.array([[1.0, 0.0], [1.0, 1.0]])
    q = np.array([0.0, -1.0])
    assert row_violation(M, q, np.array([2e-31, 1.0])) < 1e-6
    assert row_violation(M, q, np.array([1e-3, 1.0])) > 1e-6


def test_the_contact_cases_are_the_projects_lcp():
    """A floating body pulled off the floor has no equilibrium; pressed on it, it has one."""
    rng = np.random.default_rng(0)
    M, q, r = contact_case(rng, 2, 0.0, floating=True)
    assert r == 3 and lemke(M, q).ok
    M, q, _ = contact_case(rng, 2, 0.0, floating=True, lift=True)
    assert not exact.solutions(M, q) and lemke(M, q).status == "secondary ray"


def test_one_fixed_seed_round_has_no_failure():
    """scripts/check_lcp.py, one round (seed 0) of lemke without the large cases: every
    outcome is ok or an unguaranteed miss (the bimatrix games)."""
    res = subprocess.run([sys.executable, "scripts/check_lcp.py", "--rounds", "1",
                          "--no-large", "--solver", "lemke"], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stdout[-3000:] + res.stderr[-2000:]
    summary = json.loads(res.stdout.splitlines()[-1])["summary"]
    assert summary["cases"] > 700
    assert summary["ok"] + summary.get("missed_unguaranteed", 0) == summary["cases"]
