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
