"""summary.json `timings` of a run that fails or is stopped by a signal: `total` and the
phases so far (rank 0's seconds), and `stopped_in_phase`. Before, such a summary had no
`total` (the steps' `timings`, or none before step 1), so its seconds were in no phase."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys

import pytest
from signal_support import cli_with, sleep_in_a_solve
from support import CONFIGS, ROOT, mpi_env, read_summary, signal_when_ready

from app import hard_stop

# the unit load cases' solve fails (on every rank, or on rank `only`): a failure after set-up
FAIL_IN_SOLVE = cli_with("""
    from petsc4py import PETSc
    from app.assembly import solve
    from app.errors import SolveError
    only = {only}

    def solve_(self, b, x=None, **kw):
        if only is None or PETSc.COMM_WORLD.getRank() == only:
            raise SolveError("made up: the solve failed")
        raise SystemExit(0)  # (never reached on rank 0: the failure above ends the job)

    solve.LinearSolver.solve = solve_
    """)

# the factorization sleeps in Python (where a signal's handler runs) once it printed "ready"
SLEEP_IN_FACTOR = cli_with("""
    import time
    from app.assembly import solve

    def factor(self):
        print("ready", flush=True)
        time.sleep(60)

    solve.LinearSolver.factor = factor
    """)


def _phases_add_up(s: dict) -> dict:
    t = s["timings"]
    assert t["total"] > 0
    parts = sum(v for k, v in t.items() if k != "total")
    assert parts == pytest.approx(t["total"], rel=0.05, abs=0.05), t
    assert {"launch", "startup", "mesh"} <= set(t), t
    return t


def _cmd(script: str, ranks: int, out, config: str = "hertz.toml") -> list[str]:
    run = [sys.executable, "-c", script, "run", str(CONFIGS / config), "--out", str(out),
           "--quiet"]
    return run if ranks == 1 else [shutil.which("mpiexec"), "-n", str(ranks), *run]


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_failed_runs_timings_have_a_total(tmp_path, ranks):
    out = tmp_path / "o"
    res = subprocess.run(_cmd(FAIL_IN_SOLVE.replace("{only}", "None"), ranks, out), cwd=ROOT,
                         env=mpi_env(), capture_output=True, text=True, timeout=300)
    assert res.returncode != 0 and "made up: the solve failed" in res.stderr, res.stderr
    s = read_summary(out)
    assert s["status"] == "failed"
    t = _phases_add_up(s)
    assert s["stopped_in_phase"] == "solve" and t["factorization"] > 0


def test_a_run_that_fails_on_one_rank_alone_has_timings(tmp_path):
    """Rank 1 fails, mpiexec's SIGTERM ends rank 0: its watchdog writes `failed` (no
    collective there), with the phase rank 0 was in."""
    out = tmp_path / "o"
    res = subprocess.run(_cmd(FAIL_IN_SOLVE.replace("{only}", "1"), 2, out), cwd=ROOT,
                         env=mpi_env(), capture_output=True, text=True, timeout=300)
    s = read_summary(out)
    assert s["status"] == "failed", res.stderr
    _phases_add_up(s)
    assert s["stopped_in_phase"] == "solve"


def _signal_when_ready(cmd: list[str], sig: int, readies: int) -> subprocess.CompletedProcess:
    return signal_when_ready(cmd, sig, readies)[0]


@pytest.mark.parametrize("ranks,sig", [(1, signal.SIGINT), (1, signal.SIGTERM),
                                       (2, signal.SIGTERM)])
def test_an_interrupted_runs_timings_have_a_total(tmp_path, ranks, sig):
    """1 rank: the handler stops the run in Python; 2 ranks: rank 0's watchdog thread
    writes the summary at once while the main thread is inside the phase."""
    out = tmp_path / "o"
    res = _signal_when_ready(_cmd(SLEEP_IN_FACTOR, ranks, out), sig, ranks)
    s = read_summary(out)
    assert s["status"] == "interrupted", res.stderr
    assert f"error: {s['error']}" in res.stderr
    t = _phases_add_up(s)
    assert s["stopped_in_phase"] == "factorization"
    assert t["factorization"] >= 0.3


@pytest.mark.skipif(not hard_stop.available(), reason="app/_hard_stop.c not built")
def test_a_stop_inside_a_long_c_call_has_timings(tmp_path):
    """The C handler writes the text prepared when it was armed: the seconds up to the
    start of the long call, and the phase it is in."""
    out = tmp_path / "o"
    res = _signal_when_ready(_cmd(sleep_in_a_solve(), 2, out), signal.SIGINT, 2)
    s = read_summary(out)
    assert s["status"] == "interrupted", res.stderr
    _phases_add_up(s)
    assert s["stopped_in_phase"] == "solve"
