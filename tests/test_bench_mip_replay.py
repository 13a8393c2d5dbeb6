"""scripts/bench_mip.py --dump / --lcp: a searched LCP saved and replayed, so a figure of
the README's "Floating bodies" measured on one step's LCP comes with a command (before,
scratch scripts outside the repository: review12)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from tests.support import ROOT, mpi_env

SCRIPT = ROOT / "scripts" / "bench_mip.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=ROOT, env=mpi_env(),
                          capture_output=True, text=True, timeout=120)


def test_a_searched_lcp_is_saved_and_its_search_replayed(tmp_path):
    res = _run("--sizes", "6", "--seed", "3", "--dump", str(tmp_path / "d"))
    assert res.returncode == 0, res.stderr
    (record,) = [json.loads(line) for line in res.stderr.splitlines()]
    saved = np.load(tmp_path / "d" / "search_1.npz")
    rng = np.random.default_rng(3)  # the script's LCP, drawn alike
    m = rng.standard_normal((6, 6))
    np.fill_diagonal(m, 1.0)
    np.testing.assert_array_equal(saved["m"], m)
    np.testing.assert_array_equal(saved["q"], rng.standard_normal(6))
    for key in ("widen", "rows", "cols"):  # (no run: no scaling)
        np.testing.assert_array_equal(saved[key], np.ones(6))
    res = _run("--lcp", record["file"], "--unscaled", "--bounds", "10", "100",
               "--seconds", "60")
    assert res.returncode == 0, res.stderr
    cold, unscaled, search = [json.loads(line) for line in res.stderr.splitlines()]
    assert set(cold) == {"lemke", "pivots", "max_z_over_max_q"}
    assert unscaled["unscaled_lemke"] == cold["lemke"]  # (the same LCP: ones)
    assert unscaled["pivots"] == cold["pivots"]
    assert search["n"] == 6 and 1 <= len(search["bounds"]) <= 2
    assert search["words"].startswith("a mixed-integer search found")


def test_an_lcp_that_is_not_there_is_a_usage_error(tmp_path):
    res = _run("--lcp", str(tmp_path / "none.npz"))
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert res.stderr.strip().splitlines()[-1].startswith("bench_mip.py: error: --lcp ")


def test_a_runs_solves_keep_their_bases_and_a_basis_is_checked_on_an_lcp(tmp_path):
    """--dump with --run also saves each `ContactLCP.solve`'s basis (the README's E = 1e12
    basis on E = 1e13's LCP); --basis checks one on a saved LCP instead of the search."""
    res = _run("--dump", str(tmp_path / "d"), "--run", "configs/two_blocks.toml", "--set",
               "analysis.steps=1", "--out", str(tmp_path / "o"), "--quiet")
    assert res.returncode == 0, res.stderr
    basis = np.load(tmp_path / "d" / "solve_1.npy")
    assert basis.dtype == bool and basis.ndim == 1
    res = _run("--sizes", str(basis.size), "--dump", str(tmp_path / "r"))
    assert res.returncode == 0, res.stderr
    res = _run("--lcp", str(tmp_path / "r" / "search_1.npz"), "--basis",
               str(tmp_path / "d" / "solve_1.npy"))
    assert res.returncode == 0, res.stderr
    cold, check = [json.loads(line) for line in res.stderr.splitlines()]
    assert set(check) >= {"from_basis", "pivots"}, check
    res = _run("--lcp", str(tmp_path / "r" / "search_1.npz"), "--basis",
               str(tmp_path / "none.npy"))
    assert res.returncode == 2 and "error: --basis " in res.stderr.splitlines()[-1]
