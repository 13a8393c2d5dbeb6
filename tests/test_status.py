"""A truthful status on every exit: summary.json says completed, failed or interrupted and
why; signals, a full disk, a locked or stale output folder, non-finite results."""

from __future__ import annotations

import errno
import fcntl
import json
import os
import signal
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from support import CONFIGS, ROOT, mpi_env, read_summary, run_cli

from app.errors import InputError, SolveError
from app.output.status import (
    RunGuard,
    RunInterrupted,
    check_finite,
    clear_files,
    lock_folder,
)
from app.output.xdmf import ResultWriter
from app.run import write_summary

HERTZ = str(CONFIGS / "hertz.toml")


def _assert_one_line(stderr: str) -> None:
    assert "Traceback" not in stderr, stderr
    assert len([ln for ln in stderr.splitlines() if ln.startswith("error:")]) == 1, stderr


def _written_steps(out) -> list[int]:
    return sorted(int(p.name[5:9]) for p in out.glob("step_*.h5"))


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_signal_stops_cleanly_with_interrupted_status(tmp_path, sig, code):
    out = tmp_path / "o"
    cmd = [sys.executable, "-m", "app", "run", HERTZ, "--out", str(out), "--set",
           "analysis.steps=2000"]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=mpi_env(), stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while not (out / "step_0003.h5").exists() and time.time() - t0 < 120:
        time.sleep(0.05)
    proc.send_signal(sig)
    stderr = proc.communicate(timeout=120)[1]
    assert proc.returncode == code, stderr
    _assert_one_line(stderr)
    assert "interrupted" in stderr.splitlines()[-2]  # the closing summary line
    s = read_summary(out)
    assert s["status"] == "interrupted" and signal.Signals(sig).name in s["error"]
    # the summary and the files on disk agree; no temporary file is left
    assert _written_steps(out) == list(range(1, len(s["steps"]) + 1))
    assert not list(out.glob("*.tmp"))


SMALL_DISK = """
import resource, signal, sys
from petsc4py import PETSc  # MPI's shared memory first, then the limit
resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, {limit}))
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_full_disk_is_one_line_and_leaves_no_temporary_file(tmp_path):
    """A file size limit makes every write past 60 kB fail as a full disk would."""
    out = tmp_path / "o"
    cmd = [sys.executable, "-c", SMALL_DISK.format(limit=60_000), "run", HERTZ, "--out",
           str(out), "--quiet", "--set", "analysis.steps=3"]
    res = subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 2, res.stderr
    _assert_one_line(res.stderr)
    assert "cannot write the results" in res.stderr
    s = read_summary(out)
    assert s["status"] == "failed" and "cannot write" in s["error"]
    assert not list(out.glob("*.tmp"))


def test_enospc_in_the_writer_removes_the_temporary_file(tmp_path, monkeypatch):
    import app.output.xdmf as xdmf

    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    w = ResultWriter(tmp_path, pts, np.array([[0, 1, 2, 3]]), np.zeros(1, dtype=np.int64))
    disp = {"displacement": np.zeros((4, 3))}
    w.write_step(1, 1.0, disp, {"von_mises": np.zeros(1)})

    def full(fd):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(xdmf.os, "fsync", full)
    with pytest.raises(OSError) as info:
        w.write_step(2, 2.0, disp, {"von_mises": np.zeros(1)})
    assert info.value.errno == errno.ENOSPC
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "mesh.h5", "results.xdmf", "step_0001.h5"]


def test_guard_records_failed_and_interrupted(tmp_path):
    summary = {"steps": [{"step": 1}], "status": "running"}
    with pytest.raises(InputError, match="No space left"):
        with RunGuard(tmp_path, summary, write_summary, 3):
            raise OSError(errno.ENOSPC, "No space left on device")
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["status"] == "failed" and s["failed_step"] == 2 and "steps 1..1" in s["error"]
    with pytest.raises(RunInterrupted) as info:
        with RunGuard(tmp_path, summary, write_summary, 3):
            raise KeyboardInterrupt
    assert info.value.exit_code == 130 and info.value.summary["status"] == "interrupted"
    assert json.loads((tmp_path / "summary.json").read_text())["status"] == "interrupted"
    assert not (tmp_path / "summary.json.tmp").exists()


def test_check_finite():
    check_finite(1, 1, np.ones(4), 1.0)
    with pytest.raises(SolveError, match="non-finite displacements"):
        check_finite(2, 3, np.array([1.0, np.inf]), 1.0)
    with pytest.raises(SolveError, match="non-finite strain energy"):
        check_finite(2, 3, np.ones(2), float("nan"))


def test_huge_load_fails_the_step(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "--set", "load.0.pressure=1e300"])
    assert res.returncode == 2
    _assert_one_line(res.stderr)
    assert "RuntimeWarning" not in res.stderr
    s = read_summary(out)
    assert s["status"] == "failed" and s["failed_step"] == 1 and "non-finite" in s["error"]
    assert not list(out.glob("step_*.h5"))


def test_status_before_step_one_petsc_error(tmp_path):
    """A solver package PETSc knows but was not built with fails at the factorization."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "-pc_factor_mat_solver_type", "pastix"])
    assert res.returncode == 2
    _assert_one_line(res.stderr)
    s = read_summary(out)
    assert s["status"] == "failed" and "PETSc" in s["error"] and "pastix" in s["error"]
    assert s["failed_step"] == 1 and "no step completed" in s["error"]


def test_a_locked_folder_is_refused(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    with open(out / ".lock", "a") as fh:  # another run holds the folder
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"])
    assert res.returncode == 2
    _assert_one_line(res.stderr)
    assert "another run is writing into this folder" in res.stderr
    assert not (out / "summary.json").exists()  # the other run's files are left alone
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"])
    assert res.returncode == 0, res.stderr


def test_two_runs_at_once_into_one_folder(tmp_path):
    """A run holding OUT's lock (here: this test process, as a running job would) makes
    a second run into OUT a one-line error that touches nothing; once released, it runs."""
    out = tmp_path / "o"
    holder = lock_folder(out)
    (out / "summary.json").write_text('{"status": "running"}')
    try:
        second = run_cli(["run", HERTZ, "--out", str(out), "--quiet"])
        assert second.returncode == 2 and "another run" in second.stderr
        assert len(second.stderr.strip().splitlines()) == 1
        assert read_summary(out) == {"status": "running"}  # the holder's file is untouched
    finally:
        holder.close()
    again = run_cli(["run", HERTZ, "--out", str(out), "--quiet"])
    assert again.returncode == 0, again.stderr
    assert read_summary(out)["status"] == "completed"


def test_stale_step_files_of_an_earlier_run_are_cleared(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    for name in ("step_0002.h5", "step_0015.h5", "step_0003.h5.tmp", "contact.xdmf",
                 "notes.txt", "step_plot.png"):
        (out / name).write_text("old")
    res = run_cli(["run", str(CONFIGS / "cantilever.toml"), "--out", str(out), "--quiet"])
    assert res.returncode == 0, res.stderr
    names = sorted(p.name for p in out.iterdir())
    assert names == [".lock", "mesh.h5", "notes.txt", "results.xdmf", "step_0001.h5",
                     "step_plot.png", "summary.json"]
    assert clear_files(out) == ["mesh.h5", "results.xdmf", "step_0001.h5", "summary.json"]


def test_study_where_every_run_fails_exits_2(tmp_path):
    res = run_cli(["study", str(CONFIGS / "cantilever.toml"), "--levels", "1", "--methods",
                   "4", "--mesh-size", "0.5", "--out", str(tmp_path / "s"),
                   "--set", "load.0.traction=[0.0, 1e300]"])
    assert res.returncode == 2
    assert res.stderr.strip().splitlines()[-1].startswith("error: every run of the study")


def test_a_cut_short_xdmf_append_is_restored_to_the_completed_steps(tmp_path, monkeypatch):
    """A full disk can stop the in-place XDMF append part way: the failure handler
    rewrites the indexes with the steps summary.json lists and removes later step files."""
    import meshio

    from app.output import append
    from app.output.xdmf import restore_steps

    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    w = ResultWriter(tmp_path, pts, np.array([[0, 1, 2, 3]]), np.zeros(1, dtype=np.int64))
    disp = {"displacement": np.zeros((4, 3))}
    for step in (1, 2):
        w.write_step(step, float(step), disp, {"von_mises": np.zeros(1)})

    real_pwrite = os.pwrite

    def cut_short(fd, data, offset):
        real_pwrite(fd, data[: len(data) // 2], offset)  # part of the entry, no closing tags
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(append.os, "pwrite", cut_short, raising=True)
    with pytest.raises(OSError):
        w.write_step(3, 3.0, disp, {"von_mises": np.zeros(1)})
    monkeypatch.undo()
    with pytest.raises(ET.ParseError):  # the index is broken now
        ET.parse(tmp_path / "results.xdmf")
    restore_steps(w, 2)
    assert _written_steps(tmp_path) == [1, 2]
    with meshio.xdmf.TimeSeriesReader(tmp_path / "results.xdmf") as r:
        r.read_points_cells()
        assert r.num_steps == 2 and r.read_data(1)[0] == 2.0


def test_sigterm_inside_a_long_gmsh_call_stops_within_seconds(tmp_path):
    """Python handlers cannot run while gmsh meshes (minutes here); the watchdog thread
    records the status and exits after STOP_GRACE_SECONDS."""
    out = tmp_path / "o"
    cmd = [sys.executable, "-m", "app", "run", HERTZ, "--out", str(out), "--mesh-size",
           "0.02", "--allow-large"]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=mpi_env(), stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while not (out / "summary.json").exists() and time.time() - t0 < 120:
        time.sleep(0.05)
    time.sleep(1.0)  # inside gmsh by now
    t1 = time.time()
    proc.send_signal(signal.SIGTERM)
    stderr = proc.communicate(timeout=120)[1]
    assert time.time() - t1 < 30, "did not stop promptly"
    assert proc.returncode == 143, stderr
    _assert_one_line(stderr)
    s = read_summary(out)
    assert s["status"] == "interrupted" and "SIGTERM" in s["error"]


BETWEEN_RUNS = """
import sys
import app.studies.convergence

def stop(*args, **kwargs):
    raise KeyboardInterrupt

app.studies.convergence.{name} = stop
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("name", ["finish_study", "_record_row"])
def test_sigint_between_a_studys_runs_is_one_line_exit_130(tmp_path, name):
    """Ctrl-C outside a run's guard (between a study's runs, or while it writes the tables
    and plots) printed a KeyboardInterrupt traceback."""
    out = tmp_path / "s"
    cmd = [sys.executable, "-c", BETWEEN_RUNS.format(name=name), "study",
           str(CONFIGS / "cantilever.toml"), "--levels", "1", "--methods", "4", "--out",
           str(out), "--quiet"]
    res = subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 130, res.stderr
    _assert_one_line(res.stderr)
    assert res.stderr.splitlines()[-1].startswith("error: interrupted by SIGINT")
    assert read_summary(out / "L0_4SD")["status"] == "completed"


ONE_FAILS = """
import sys
import app.studies.convergence
from app.errors import SolveError
real = app.studies.convergence.run

def run(cfg, opts):
    if "FEM-Q4" in opts.progress_prefix:
        raise SolveError("no static equilibrium at step 1: made up")
    return real(cfg, opts)

app.studies.convergence.run = run
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_study_says_which_runs_failed_and_why(tmp_path):
    """A run that failed left no trace in the study's output (with --quiet nothing at all
    but its own summary.json)."""
    out = tmp_path / "s"
    cmd = [sys.executable, "-c", ONE_FAILS, "study", str(CONFIGS / "cantilever.toml"),
           "--levels", "1", "--methods", "4,q4", "--out", str(out), "--quiet"]
    res = subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr
    tables = (out / "study_tables.md").read_text()
    assert ("- level 0 of 0..0 FEM-Q4: no static equilibrium at step 1: made up" in tables), tables


def _mpiexec_signal(cmd: list[str], out, ready, sig=signal.SIGTERM) -> tuple[str, float]:
    """Start `cmd` under `mpiexec -n 2`, send `sig` to mpiexec once `ready()` holds;
    returns stderr and the seconds from the signal to mpiexec's exit."""
    import shutil

    mpi = [shutil.which("mpiexec"), "-n", "2", sys.executable, "-m", "app"]
    proc = subprocess.Popen(mpi + cmd, cwd=ROOT, env=mpi_env(), stderr=subprocess.PIPE,
                            text=True)
    t0 = time.time()
    while not ready() and time.time() - t0 < 120:
        time.sleep(0.05)
    t1 = time.time()
    proc.send_signal(sig)
    stderr = proc.communicate(timeout=120)[1]
    return stderr, time.time() - t1


def test_sigterm_to_mpiexec_inside_gmsh_records_interrupted(tmp_path):
    """Open MPI's mpiexec forwards SIGTERM (also for Ctrl-C) and sends SIGKILL 1 s later:
    rank 0 must have written the status by then (it stayed `running` with the 3 s grace)."""
    out = tmp_path / "o"
    cmd = ["run", HERTZ, "--out", str(out), "--mesh-size", "0.02", "--allow-large"]
    stderr, waited = _mpiexec_signal(
        cmd, out, lambda: (out / "summary.json").exists() and time.sleep(1.0) is None)
    assert waited < 30, "did not stop promptly"
    assert "Traceback" not in stderr, stderr
    s = read_summary(out)
    assert s["status"] == "interrupted" and "SIGTERM" in s["error"], s.get("error")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_signal_to_mpiexec_between_steps_records_interrupted(tmp_path, sig):
    """Between steps on 2 ranks: the summary says `interrupted` and agrees with the step
    files (a rank that stopped by itself left rank 0 blocked in a collective until
    mpiexec's SIGKILL, status `running`, for 2 of 6 signals)."""
    out = tmp_path / "o"
    cmd = ["run", str(CONFIGS / "cattaneo.toml"), "--out", str(out), "--quiet", "--set",
           "analysis.steps=400", "--set", "support.1.ramp=[1,100]", "--set",
           "load.0.ramp=[101,400]"]
    for _ in range(3):  # the failure was a race: three signals at different steps
        stderr, _ = _mpiexec_signal(cmd, out, lambda: (out / "step_0010.h5").exists(), sig)
        assert "Traceback" not in stderr, stderr
        s = read_summary(out)
        assert s["status"] == "interrupted", stderr
        assert _written_steps(out) == list(range(1, len(s["steps"]) + 1))
        assert not list(out.glob("*.tmp"))


def test_full_disk_on_two_ranks_fails_instead_of_hanging(tmp_path):
    """Only rank 0 writes: its OSError alone left the ranks in different collectives
    (rank 0 in a barrier on its way out, rank 1 in the next step) and the run hung with
    `status` at `running` (a 200 kB tmpfs; here a file size limit)."""
    import shutil

    out = tmp_path / "o"
    cmd = [shutil.which("mpiexec"), "-n", "2", sys.executable, "-c",
           SMALL_DISK.format(limit=60_000), "run", HERTZ, "--out", str(out), "--quiet",
           "--set", "analysis.steps=3"]
    res = subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                         timeout=90)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr, res.stderr
    assert len([ln for ln in res.stderr.splitlines() if ln.startswith("error:")]) == 1
    s = read_summary(out)
    assert s["status"] == "failed" and "cannot write" in s["error"]
    assert _written_steps(out) == list(range(1, len(s["steps"]) + 1))
    assert not list(out.glob("*.tmp"))


def test_interrupt_after_the_last_step_says_so(tmp_path):
    """A signal during the final output of a 1-step run read `during step 2/1` before."""
    summary = {"steps": [{"step": 1}], "status": "running"}
    with pytest.raises(RunInterrupted) as info:
        with RunGuard(tmp_path, summary, write_summary, 1):
            raise KeyboardInterrupt
    assert info.value.summary["error"].startswith(
        "interrupted by SIGINT after the last step (1/1); steps 1..1 are written")


def test_a_study_stop_before_the_runs_watchdog_records_interrupted(tmp_path):
    """A sweep's watchdog that ends the job between this guard's `running` summary and its
    own watchdog (1 of 50 trials on 2 ranks) ran only the study's hooks: the run's summary
    stayed `running`. The guard's hook records `interrupted`, and is gone after the run."""
    from app.output import status

    summary = {"steps": [], "status": "running"}
    with RunGuard(tmp_path, summary, write_summary, 2):
        status._run_stop_hooks("interrupted by SIGTERM between the runs; what completed "
                               "before it is written")
        s = json.loads((tmp_path / "summary.json").read_text())
        assert s["status"] == "interrupted", s
        assert s["error"] == "interrupted by SIGTERM during step 1/2; no step completed"
    other = tmp_path / "other"
    with RunGuard(other, {"steps": [], "status": "running"}, write_summary, 1):
        pass
    status._run_stop_hooks("interrupted by SIGINT between the runs")
    assert json.loads((other / "summary.json").read_text())["status"] == "running"


def test_a_summary_with_only_steps_and_trailing_keys_is_json(tmp_path):
    """With no head key the opening brace was cut off with the head's closing one."""
    summary = {"steps": [], "status": "running"}
    write_summary(tmp_path, summary)
    assert json.loads((tmp_path / "summary.json").read_text()) == summary
    summary["steps"].append({"step": 1})
    write_summary(tmp_path, summary)
    assert json.loads((tmp_path / "summary.json").read_text()) == summary
