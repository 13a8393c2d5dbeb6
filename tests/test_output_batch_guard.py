"""app/output/batch_guard.py: a study or sweep stopped by SIGINT / SIGTERM leaves the tables
of the runs that completed, wherever the signal comes and on any number of ranks."""

from __future__ import annotations

import signal
import time

from signal_support import cli_with, run_script, start_script, stop_in_run
from support import CONFIGS, read_csv, read_summary


def test_a_study_interrupted_on_one_rank_writes_the_tables_and_plots(tmp_path):
    """Ctrl-C in a study's second run left study.csv alone: no study_tables.md, no plots."""
    out = tmp_path / "s"
    res = run_script(stop_in_run(2), ["study", str(CONFIGS / "cantilever.toml"), "--levels",
                                      "2", "--methods", "4", "--out", str(out), "--quiet"])
    assert res.returncode == 130, res.stderr
    lines = res.stderr.splitlines()
    assert lines[-1].startswith("error: interrupted by SIGINT"), res.stderr
    assert lines[0].startswith("study: interrupted; the 1 completed runs are in study.csv "
                               "and study_tables.md, and the plots"), res.stderr
    assert [r["level"] for r in read_csv(out / "study.csv")] == ["0"]
    assert "| 0 " in (out / "study_tables.md").read_text()
    assert list(out.glob("*.png"))


PAUSE_BEFORE_SECOND_RUN = cli_with("""
import time
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
""")


def test_a_study_signalled_between_runs_on_two_ranks_keeps_its_tables(tmp_path):
    """On 2 ranks a signal between a study's runs ended the job with no line and no
    study_tables.md (the ranks died on the default SIGTERM action)."""
    out = tmp_path / "s"
    proc = start_script(PAUSE_BEFORE_SECOND_RUN, ["study", str(CONFIGS / "cantilever.toml"),
                                                  "--levels", "2", "--methods", "4", "--out",
                                                  str(out), "--quiet"], ranks=2)
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


def test_a_sweep_interrupted_on_one_rank_draws_its_plots(tmp_path):
    out = tmp_path / "w"
    res = run_script(stop_in_run(2, "app.studies.sweep"), [
        "study", str(CONFIGS / "two_blocks.toml"), "--sweep",
        "interface.interface.mu=0.2,0.4,0.6", "--out", str(out), "--quiet"])
    assert res.returncode == 130, res.stderr
    assert "sweep: interrupted; its 1 rows are in sweep.csv and the plots" in res.stderr
    assert "with a row for each of the 2 runs that did not complete" in res.stderr
    rows = read_csv(out / "sweep.csv")  # (before: the completed row alone)
    assert [(r["interface.interface.mu"], r["status"]) for r in rows] == [
        ("0.2", "completed"), ("0.4", "not run"), ("0.6", "not run")]
    assert list(out.glob("*.png"))
