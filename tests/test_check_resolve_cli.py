"""scripts/check_resolve.py: random LCPs through the re-solve on pair states
(`ContactLCP._polished`). Frictionless ones (C positive definite: a P-matrix LCP, on which
Murty's least-index rule terminates) all settle, from any basis; --compare of a run with
itself reports no difference."""

from __future__ import annotations

import json
import os
import subprocess
import sys

from support import ROOT


def _run(*args: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    res = subprocess.run([sys.executable, "scripts/check_resolve.py", *args], cwd=ROOT,
                         env=env, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def test_random_frictionless_lcps_all_settle_and_a_run_equals_itself(tmp_path):
    out = tmp_path / "run.json"
    got = _run("--cases", "90", "--out", str(out))
    assert got["cases"] == 90
    assert got["settled_by_kind"]["frictionless"] == [30, 30]
    assert 0 < got["solves_max"] <= 24  # UNSHIFTED_PIVOTS + SINGLE_FLIPS
    same = _run("--compare", str(out), str(out))
    assert same["settled_first_only"] == same["settled_second_only"] == same["differ"] == []
