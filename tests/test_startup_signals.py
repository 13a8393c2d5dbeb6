"""SIGINT / SIGTERM before a run's guard is in force (app/output/startup_signals.py): during the
start-up phase, and between the guard's clean-up of OUT and its first summary.json.

Before: SIGTERM (what mpiexec sends every rank on Ctrl-C) killed the run there with
nothing written: the earlier run's `completed` summary.json and step files stayed in OUT
as if they were this run's, or only summary.json.tmp was left."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import pytest
from support import CONFIGS, ROOT, mpi_env, run_cli

HOOK = r"""
import os, signal, sys
import app.cli as cli
import app.output.status as st
if os.environ["HOOK"] == "startup":  # inside the config and size checks
    orig = cli.check_run_input
    def hooked(*a, **k):
        signal.raise_signal(signal.SIGTERM)
        return orig(*a, **k)
    cli.check_run_input = hooked
else:  # right after the guard removed the earlier run's files, before its summary
    orig = st.clear_files
    def hooked(*a, **k):
        removed = orig(*a, **k)
        if len(a) < 2 and "pattern" not in k:
            signal.raise_signal(signal.SIGTERM)
        return removed
    st.clear_files = hooked
sys.exit(cli.main())
"""


def _interrupted_run(tmp_path, hook: str, ranks: int) -> tuple[subprocess.CompletedProcess, dict]:
    out = tmp_path / "out"
    first = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"])
    assert first.returncode == 0, first.stderr  # an earlier, completed run in OUT
    script = tmp_path / "hook.py"
    script.write_text(HOOK)
    cmd = [sys.executable, str(script), "run", str(CONFIGS / "hertz.toml"), "--out", str(out),
           "--quiet"]
    if ranks > 1:
        cmd = [shutil.which("mpiexec"), "-n", str(ranks), *cmd]
    res = subprocess.run(cmd, cwd=ROOT, env={**mpi_env(), "HOOK": hook}, capture_output=True,
                         text=True, timeout=300)
    assert sorted(p.name for p in out.iterdir()) == [".lock", "summary.json"], res.stderr
    return res, json.loads((out / "summary.json").read_text())


@pytest.mark.parametrize("ranks", [1, pytest.param(2, marks=pytest.mark.mpi)])
@pytest.mark.parametrize("hook, when", [("startup", "start-up"), ("guard", "step 1/1")])
def test_sigterm_before_the_guard_records_this_run_as_interrupted(tmp_path, hook, when, ranks):
    """`startup`: inside the config and size checks; `guard`: between the guard's clean-up
    of OUT and its first summary.json (no summary.json.tmp left)."""
    res, s = _interrupted_run(tmp_path, hook, ranks)
    assert s["status"] == "interrupted" and s["config"].endswith("hertz.toml")
    assert s["error"] == f"interrupted by SIGTERM during {when}; no step completed"
    assert f"error: interrupted by SIGTERM during {when}" in res.stderr
    if ranks == 1:
        assert res.returncode == 143
    t = s["timings"]  # (before: none) the start-up's seconds so far, in its phases
    assert s["stopped_in_phase"] == "startup" and set(t) == {"launch", "startup", "total"}, t
    assert t["launch"] > 0 and t["startup"] > 0
    assert t["launch"] + t["startup"] == pytest.approx(t["total"], abs=1e-6)
