"""app/output/batch_guard.py: a study or sweep stopped by SIGINT / SIGTERM leaves the tables
of the runs that completed, wherever the signal comes and on any number of ranks."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time

from support import CONFIGS, ROOT, mpi_env, read_csv, read_summary

STOP_IN_SECOND_RUN = """
import sys
import app.studies.convergence
real = app.studies.convergence.run
calls = []

def run(cfg, opts):
    calls.append(opts)
    if len(calls) == 2:
        raise KeyboardInterrupt  # Ctrl-C inside the second run
    return real(cfg, opts)

app.studies.convergence.run = run
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_study_interrupted_on_one_rank_writes_the_tables_and_plots(tmp_path):
    """Ctrl-C in a study's second run left study.csv alone: no study_tables.md, no plots."""
    out = tmp_path / "s"
    cmd = [sys.executable, "-c", STOP_IN_SECOND_RUN, "study",
           str(CONFIGS / "cantilever.toml"), "--levels", "2", "--methods", "4", "--out",
           str(out), "--quiet"]
    res = subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 130, res.stderr
    lines = res.stderr.splitlines()
    assert lines[-1].startswith("error: interrupted by SIGINT"), res.stderr
    assert lines[0].startswith("study: interrupted; the 1 completed runs are in study.csv "
                               "and study_tables.md, and the plots"), res.stderr
    assert [r["level"] for r in read_csv(out / "study.csv")] == ["0"]
    assert "| 0 " in (out / "study_tables.md").read_text()
    assert list(out.glob("*.png"))


PAUSE_BEFORE_SECOND_RUN = """
import sys, time
import app.studies.convergence
real = app.studies.convergence._try_run
calls = []

def try_run(cfg, opts, failures, t0):
    calls.append(opts)
    if len(calls) == 2:
        from petsc4py import PETSc
        if PETSc.COMM_WORLD.getRank() == 0:  # rank 0 is past the first run's recording
            print("ready", flush=True)
        time.sleep(60)  # between the runs, in Python
    return real(cfg, opts, failures, t0)

app.studies.convergence._try_run = try_run
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_study_signalled_between_runs_on_two_ranks_keeps_its_tables(tmp_path):
    """On 2 ranks a signal between a study's runs ended the job with no line and no
    study_tables.md (the ranks died on the default SIGTERM action)."""
    out = tmp_path / "s"
    cmd = [shutil.which("mpiexec"), "-n", "2", sys.executable, "-c",
           PAUSE_BEFORE_SECOND_RUN, "study", str(CONFIGS / "cantilever.toml"), "--levels",
           "2", "--methods", "4", "--out", str(out), "--quiet"]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=mpi_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "ready"
    time.sleep(0.3)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert "Traceback" not in stderr, stderr
    assert "error: interrupted by SIGTERM between the runs" in stderr, stderr
    assert "study: interrupted; the 1 completed runs" in stderr, stderr
    assert read_summary(out / "L0_4SD")["status"] == "completed"
    assert [r["level"] for r in read_csv(out / "study.csv")] == ["0"]
    assert "| 0 " in (out / "study_tables.md").read_text()


STOP_IN_SECOND_SWEEP_RUN = STOP_IN_SECOND_RUN.replace("app.studies.convergence",
                                                      "app.studies.sweep")


def test_a_sweep_interrupted_on_one_rank_draws_its_plots(tmp_path):
    out = tmp_path / "w"
    cmd = [sys.executable, "-c", STOP_IN_SECOND_SWEEP_RUN, "study",
           str(CONFIGS / "two_blocks.toml"), "--sweep", "interface.interface.mu=0.2,0.4,0.6",
           "--out", str(out), "--quiet"]
    res = subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 130, res.stderr
    assert "sweep: interrupted; its 1 rows are in sweep.csv and the plots" in res.stderr
    assert "with a row for each of the 2 runs that did not complete" in res.stderr
    rows = read_csv(out / "sweep.csv")  # (before: the completed row alone)
    assert [(r["interface.interface.mu"], r["status"]) for r in rows] == [
        ("0.2", "completed"), ("0.4", "not run"), ("0.6", "not run")]
    assert list(out.glob("*.png"))
