"""A study or sweep that stops on bad input, or on a signal before its first run completes,
leaves OUT/summary.json with `failed` or `interrupted` and the `error:` line
(app/studies/batch_status.py). Before, it left no summary.json in OUT."""

from __future__ import annotations

import fcntl
import shutil
import signal
import subprocess
import sys
import time

import pytest
from signal_support import sleep_in_a_solve, start_script
from support import CONFIGS, ROOT, mpi_env, read_csv, read_summary, run_cli

from app import hard_stop

HERTZ = str(CONFIGS / "hertz.toml")
FAST = ["--mesh-size", "1.0", "--quiet"]


def _error_line(res) -> str:
    """The one `error:` line (the last on stderr; a sweep's `failed:` lines come before)."""
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    errors = [ln for ln in lines if ln.startswith("error: ")]
    assert len(errors) == 1 and lines[-1] == errors[0], res.stderr
    return errors[0][len("error: "):]


def _failed_summary(out, res, kind: str) -> dict:
    """OUT/summary.json of a failed study: its error is the printed line."""
    s = read_summary(out)
    assert s["status"] == "failed" and s["error"] == _error_line(res)
    assert s["command"] == "study" and s["study"] == kind
    assert s["config"].endswith(".toml")
    assert s["provenance"]["start_time"] and "study" in s["provenance"]["argv"]
    return s


@pytest.mark.parametrize("args, kind, reason", [
    (["--levels", "0"], "convergence", "--levels must be >= 1"),
    (["--first-level", "-1"], "convergence", "--first-level >= 0"),
    (["--reference-levels", "9"], "convergence", "--reference-levels must be 0..3"),
    (["--methods", "5"], "convergence", "--methods: '5' is not one of"),
    (["--levels", "1", "--reference-method", "BOGUS"], "convergence",
     "--reference-method BOGUS is not among the methods"),
    (["--levels", "1", "--methods", "4", "--refine", "2"], "convergence",
     "apply with --sweep only"),
    (["--set", "mesh.size=-1", "--levels", "2"], "convergence", "mesh.size must be > 0"),
    (["--set", "analysis.sdd=1"], "convergence", "unknown key analysis.sdd"),
    (["--sweep", "noequals"], "sweep", "use KEY=V1,V2"),
    (["--sweep", "interface.contact.mu=0.1", "--sweep", "interface.contact.mu=0.2"], "sweep",
     "is swept twice"),
    (["--sweep", "interface.contact.mu=0.1", "--levels", "2"], "sweep",
     "--levels does not apply with --sweep"),
    (["--sweep", "interface.contact.mu=0.1", "--refine", "-1"], "sweep", "--refine must be"),
    (["--sweep", "interface.contact.mu=0.1", "--at-step", "99"], "sweep",
     "--at-step 99: the run has 1 steps"),
    (["--sweep", "interface.contact.muu=0.0,0.1"], "sweep",
     "every run of the sweep failed (first: interface 'contact': unknown key 'muu'"),
])
def test_bad_study_options_are_recorded_as_failed(tmp_path, args, kind, reason):
    out = tmp_path / "o"
    res = run_cli(["study", HERTZ, "--out", str(out), *FAST, *args])
    assert reason in _failed_summary(out, res, kind)["error"]


@pytest.mark.parametrize("text, reason", [("x = [", "is not valid TOML"),
                                          (None, "does not exist")])
def test_bad_or_missing_config_file_is_recorded_as_failed(tmp_path, text, reason):
    config = tmp_path / "scene.toml"
    if text is not None:
        config.write_text(text)
    out = tmp_path / "o"
    res = run_cli(["study", str(config), "--out", str(out), "--quiet"])
    assert reason in _failed_summary(out, res, "convergence")["error"]


def test_a_failed_study_replaces_an_earlier_completed_summary(tmp_path):
    """A completed sweep, then a study into the same OUT that stops on bad input: OUT's
    summary.json says failed (an earlier study's `completed` one is not left standing),
    and a completed study or sweep says so, with its rows."""
    out = tmp_path / "o"
    res = run_cli(["study", HERTZ, "--out", str(out), *FAST, "--sweep",
                   "interface.contact.mu=0.1"])
    assert res.returncode == 0, res.stderr
    s = read_summary(out)
    assert (s["status"], s["study"], s["rows"], s["results"]) == ("completed", "sweep", 1,
                                                                   "sweep.csv")
    assert s["end_time"] >= s["provenance"]["start_time"]
    assert read_summary(out / "run_000")["status"] == "completed"
    res = run_cli(["study", HERTZ, "--out", str(out), *FAST, "--methods", "abc"])
    assert "--methods: 'abc'" in _failed_summary(out, res, "convergence")["error"]


def test_an_out_that_cannot_be_written_is_named_in_the_error(tmp_path):
    (tmp_path / "file").write_text("")
    out = tmp_path / "file" / "o"
    res = run_cli(["study", HERTZ, "--out", str(out), "--methods", "5"])
    line = _error_line(res)
    assert line.startswith("--methods: '5' is not one of")
    assert f"no summary.json written: --out {out}: cannot write there" in line
    res = run_cli(["study", HERTZ, "--out", str(out), *FAST, "--sweep", "a.b=1"])
    assert _error_line(res).startswith(f"--out {out}: cannot write there")


def test_another_programs_summary_or_a_locked_out_is_left_alone(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "summary.json").write_text('{"theirs": 1}')
    res = run_cli(["study", HERTZ, "--out", str(out), "--levels", "0"])
    assert "holds summary.json of another program" in _error_line(res)
    assert read_summary(out) == {"theirs": 1}
    res = run_cli(["study", HERTZ, "--out", str(out), *FAST, "--sweep", "a.b=1"])
    assert "holds summary.json of another program" in _error_line(res)
    assert read_summary(out) == {"theirs": 1}
    (out / "summary.json").write_text('{"status": "running"}')
    with open(out / ".lock", "a") as fh:  # another run writes there
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        for args in (["--levels", "0"], ["--levels", "1", "--methods", "4"]):
            res = run_cli(["study", HERTZ, "--out", str(out), *FAST, *args])
            assert "another run is writing into this folder" in _error_line(res)
    assert read_summary(out) == {"status": "running"}


@pytest.mark.mpi
def test_bad_input_and_every_run_failed_on_two_ranks(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["study", HERTZ, "--out", str(out), *FAST, "--methods", "5"], ranks=2)
    assert res.returncode != 0 and res.stderr.count("error: --methods: '5'") == 1
    s = read_summary(out)
    assert s["status"] == "failed" and s["error"].startswith("--methods: '5'")
    assert s["provenance"]["ranks"] == 2
    res = run_cli(["study", HERTZ, "--out", str(out), *FAST, "--sweep",
                   "interface.contact.muu=0.0,0.1"], ranks=2)
    assert res.returncode != 0
    s = read_summary(out)
    assert s["status"] == "failed" and s["study"] == "sweep"
    assert s["error"].startswith("every run of the sweep failed (first: interface 'contact'")
    assert s["provenance"]["ranks"] == 2


HOOK = r"""
import os, signal, sys
import app.cli as cli
name = getattr(signal, os.environ["SIG"])
if os.environ["HOOK"] == "startup":  # inside the study's config and size checks
    import app.cli as where
    attr = "check_run_input"
else:  # inside the first run, before its mesh
    import app.run as where
    attr = "build_model"
orig = getattr(where, attr)
def hooked(*a, **k):
    signal.raise_signal(name)
    return orig(*a, **k)
setattr(where, attr, hooked)
sys.exit(cli.main())
"""


@pytest.mark.parametrize("ranks", [1, pytest.param(2, marks=pytest.mark.mpi)])
@pytest.mark.parametrize("hook, sig, sweep", [("startup", "SIGTERM", False),
                                              ("startup", "SIGINT", True),
                                              ("run", "SIGINT", False),
                                              ("run", "SIGTERM", True)])
def test_a_signal_before_the_first_run_completes_is_recorded(tmp_path, hook, sig, sweep,
                                                             ranks):
    """OUT/summary.json says interrupted with the printed reason (an earlier study's
    `completed` one does not stay); so does the run's, inside the first run. In the
    study's checks the start-up handler stops at once (app/output/startup_signals.py)."""
    out = tmp_path / "o"
    out.mkdir()
    (out / "summary.json").write_text('{"command": "study", "status": "completed"}')
    script = tmp_path / "hook.py"
    script.write_text(HOOK)
    what = ["--sweep", "interface.contact.mu=0.1,0.2"] if sweep else ["--levels", "1",
                                                                     "--methods", "4"]
    cmd = [sys.executable, str(script), "study", HERTZ, "--out", str(out), *FAST, *what]
    if ranks > 1:
        cmd = [shutil.which("mpiexec"), "-n", str(ranks), *cmd]
    res = subprocess.run(cmd, cwd=ROOT, env={**mpi_env(), "HOOK": hook, "SIG": sig},
                         capture_output=True, text=True, timeout=300)
    when = "start-up" if hook == "startup" else "step 1/1"
    reason = f"interrupted by {sig} during {when}; no step completed"
    assert f"error: {reason}" in res.stderr
    if ranks == 1:
        assert res.returncode == {"SIGINT": 130, "SIGTERM": 143}[sig]
    s = read_summary(out)
    assert (s["status"], s["error"], s["study"]) == ("interrupted", reason,
                                                     "sweep" if sweep else "convergence")
    run = out / ("run_000" if sweep else "L0_4SD") / "summary.json"
    if hook == "startup":
        assert not run.exists()
    else:
        assert (read_summary(run.parent)["status"], read_summary(run.parent)["error"]) == (
            "interrupted", reason)


STOP_IN_THE_FIRST_SOLVE = sleep_in_a_solve()  # a long PETSc call of the first run


@pytest.mark.mpi
@pytest.mark.skipif(not hard_stop.available(), reason="app/_hard_stop.c not built")
def test_a_signal_inside_the_first_runs_factorization_on_two_ranks(tmp_path):
    """Rank 0's C handler (app/_hard_stop.c) writes the study's summary after the run's:
    before, Ctrl-C to mpiexec there left none in OUT (4 of 6 real signals at 1.5-9 s
    into a hertz study at level 3)."""
    assert getattr(hard_stop._library(), "hard_stop_extra", None) is not None, (
        "app/_hard_stop.c was built before hard_stop_extra: rebuild it (pip install -e .)")
    out = tmp_path / "o"
    proc = start_script(STOP_IN_THE_FIRST_SOLVE, ["study", HERTZ, "--out", str(out), *FAST,
                                                  "--levels", "1", "--methods", "4"], ranks=2)
    assert "ready" in proc.stdout.readline()
    time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    reason = "interrupted by SIGTERM during step 1/1; no step completed"
    assert f"error: {reason}" in err
    s = read_summary(out)
    assert (s["status"], s["error"], s["command"]) == ("interrupted", reason, "study")
    assert read_summary(out / "L0_4SD")["error"] == reason
    assert not list(out.glob("*.tmp"))


STOP_IN_THE_SECOND_RUNS_SOLVE = sleep_in_a_solve('(out / "sweep.csv").exists()')


@pytest.mark.mpi
@pytest.mark.skipif(not hard_stop.available(), reason="app/_hard_stop.c not built")
def test_a_signal_inside_a_later_sweep_runs_factorization_gives_the_sweeps_outcome(tmp_path):
    """The C handler writes what the sweep's stop hook writes on the Python path: sweep.csv
    with the stopped run `interrupted` and the later ones `not run`, and the `sweep:` line
    after the `error:` line. Before, it wrote the run's and the study's summary only:
    sweep.csv had the first run's row alone and no `sweep:` line was printed."""
    assert getattr(hard_stop._library(), "hard_stop_add", None) is not None, (
        "app/_hard_stop.c was built before hard_stop_add: rebuild it (pip install -e .)")
    out = tmp_path / "o"
    proc = start_script(STOP_IN_THE_SECOND_RUNS_SOLVE, [
        "study", HERTZ, "--out", str(out), *FAST, "--sweep",
        "interface.contact.mu=0.0,0.1,0.2"], ranks=2)
    assert "ready" in proc.stdout.readline()
    time.sleep(0.2)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    reason = "interrupted by SIGTERM during step 1/1; no step completed"
    lines = [ln for ln in err.splitlines() if ln.startswith(("error:", "sweep:"))]
    assert lines == [f"error: {reason}", "sweep: interrupted; its 1 rows are in sweep.csv "
                     f"(no plots on several ranks), in {out}, with a row for each of the 2 "
                     "runs that did not complete"], err
    rows = read_csv(out / "sweep.csv")
    assert [(r["interface.contact.mu"], r["status"]) for r in rows] == [
        ("0.0", "completed"), ("0.1", "interrupted"), ("0.2", "not run")]
    assert rows[1]["error"] == "the sweep was interrupted"
    assert (read_summary(out / "run_001")["status"], read_summary(out)["error"]) == (
        "interrupted", reason)
    assert not list(out.rglob("*.tmp"))


def _usage_error(res, command: str) -> str:
    """argparse's error line (last on stderr, after its usage), without the prefix."""
    assert res.returncode == 2, res.stderr
    last = res.stderr.strip().splitlines()[-1]
    prefix = f"python -m app{command}: error: "
    assert last.startswith(prefix), res.stderr
    return last[len(prefix):]


@pytest.mark.parametrize("args, reason", [
    (["--levels", "x"], "argument --levels: invalid int value: 'x'"),
    (["--reference", "bogus"], "argument --reference: invalid choice: 'bogus'"),
    (["--levels", "--out", "{OUT}"], "argument --levels: expected one argument"),
])
def test_a_command_line_argparse_refuses_is_recorded_as_failed(tmp_path, args, reason):
    """Before PETSc starts (app/startup/early_failure.py): argparse's usage and line as before."""
    out = tmp_path / "o"
    res = run_cli(["study", HERTZ, *[str(out) if a == "{OUT}" else a for a in args],
                   "--out", str(out)])
    line = _usage_error(res, " study")
    assert line.startswith(reason)
    s = read_summary(out)
    assert (s["status"], s["error"], s["command"], s["study"]) == ("failed", line, "study",
                                                                    "convergence")
    assert s["provenance"]["argv"][1:3] == ["study", HERTZ]


def test_an_unknown_double_dash_option_and_a_refused_petsc_option_are_recorded(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["study", HERTZ, "--out", str(out), "--sweep", "a.b=1", "--nope"])
    line = _usage_error(res, "")
    assert line == "unknown option --nope (PETSc options take a single dash)"
    assert (read_summary(out)["error"], read_summary(out)["study"]) == (line, "sweep")
    res = run_cli(["study", HERTZ, "--out", str(out), "-options_file", str(tmp_path / "no")])
    line = _error_line(res)
    assert line.startswith("PETSc cannot start with the options -options_file")
    s = read_summary(out)
    assert (s["status"], s["error"], s["study"]) == ("failed", line, "convergence")


@pytest.mark.mpi
def test_a_refused_command_line_on_two_ranks(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["study", HERTZ, "--out", str(out), "--levels", "x"], ranks=2)
    assert res.returncode != 0
    s = read_summary(out)
    assert s["status"] == "failed" and s["error"] == "argument --levels: invalid int value: 'x'"
    # argparse's usage and line once (rank 0), not once per rank (before: twice)
    assert res.stderr.count("error: argument --levels") == 1, res.stderr
    assert res.stderr.count("usage:") == 1, res.stderr
