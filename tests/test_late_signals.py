"""app/output/late_signals.py: a signal after a command's runs (rank 0 drawing the plots)
or at the job's end (Python's, PETSc's and MPI's shutdown) gives a line and an interrupt
exit, never a silent death; on 2 ranks the ranks then wait in MPI_Finalize, which
mpiexec no longer completes once it has been sent Ctrl-C."""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
import time

import pytest
from support import CONFIGS, ROOT, mpi_env, read_csv, read_summary

from app.output.late_signals import ENDING, OUTSIDE

# after main returns, rank 0 says so and waits for the file GO (the test creates it once
# it has signalled), then the process ends as `python -m app` does: into MPI_Finalize
END_PHASE = """
import os, sys, time
from app.cli import main
code = main(sys.argv[2:])
from petsc4py import PETSc
if PETSc.COMM_WORLD.getRank() == 0:
    print("ended", flush=True)
    while not os.path.exists(sys.argv[1]):
        time.sleep(0.01)
sys.exit(code)
"""

# a sweep whose rank 0 is drawing its plots (after the sweep's guard) when the signal comes
IN_THE_PLOTS = """
import sys, time
import app.studies.sweep
def plot_sweep(*args, **kwargs):
    print("plotting", flush=True)
    time.sleep(60)
app.studies.sweep.plot_sweep = plot_sweep
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def _start(script: str, args: list[str], ranks: int) -> subprocess.Popen:
    cmd = [sys.executable, "-c", script, *args]
    if ranks > 1:
        cmd = [shutil.which("mpiexec"), "-n", str(ranks), *cmd]
    return subprocess.Popen(cmd, cwd=ROOT, env=mpi_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("ranks, sig, code", [(1, signal.SIGINT, 130),
                                              (1, signal.SIGTERM, 143),
                                              pytest.param(2, signal.SIGINT, 1,
                                                           marks=pytest.mark.mpi)])
def test_a_signal_at_the_jobs_end_says_the_work_completed(tmp_path, ranks, sig, code):
    """Before: 1 rank, a KeyboardInterrupt traceback or death by SIGTERM; 2 ranks (Ctrl-C
    to mpiexec), the ranks waited in MPI_Finalize and died on mpiexec's SIGTERM: exit 1
    and no line."""
    out, go = tmp_path / "o", tmp_path / "go"
    proc = _start(END_PHASE, [str(go), "run", str(CONFIGS / "patch.toml"), "--out",
                              str(out), "--quiet"], ranks)
    assert proc.stdout.readline().strip() == "ended"
    proc.send_signal(sig)  # (to mpiexec: the ranks get SIGTERM 1 s later)
    time.sleep(0.1)
    go.touch()  # every rank is in the shutdown now
    _, stderr = proc.communicate(timeout=60)
    name = "SIGTERM" if ranks > 1 else sig.name  # what mpiexec sends the ranks
    assert proc.returncode == code, stderr
    assert stderr.splitlines()[-1] == ENDING.format(name).strip(), stderr
    assert "Traceback" not in stderr, stderr
    assert read_summary(out)["status"] == "completed"


@pytest.mark.parametrize("ranks", [1, pytest.param(2, marks=pytest.mark.mpi)])
def test_sigterm_while_rank_0_draws_a_sweeps_plots_is_an_interrupt(tmp_path, ranks):
    """After the sweep's guard SIGTERM had its default action: the job died with no line
    (1 rank: exit -15; 2 ranks: mpiexec's 1)."""
    out = tmp_path / "w"
    proc = _start(IN_THE_PLOTS, ["study", str(CONFIGS / "patch.toml"), "--sweep",
                                 "interface.interface.mu=0.2,0.4", "--out", str(out),
                                 "--quiet"], ranks)
    assert proc.stdout.readline().strip() == "plotting"
    proc.send_signal(signal.SIGTERM if ranks == 1 else signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == (143 if ranks == 1 else 1), stderr
    assert stderr.splitlines()[-1] == "error: " + OUTSIDE.format("SIGTERM"), stderr
    assert [r["status"] for r in read_csv(out / "sweep.csv")] == ["completed"] * 2


# a study whose config checks take long (the start-up, before the study's guard)
SLOW_START = """
import sys, time
import app.config
real = app.config.load_config
def load_config(*args, **kwargs):
    print("loading", flush=True)
    time.sleep(30)
    return real(*args, **kwargs)
app.config.load_config = load_config
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.mpi
def test_ctrl_c_in_a_studys_start_up_on_two_ranks_prints_the_line(tmp_path):
    """A study only recorded a start-up signal for its first run's guard: when the
    start-up took more than mpiexec's 1 s from SIGTERM to SIGKILL, the job ended with no
    line (and a rank 1 that exited at once got rank 0 killed before it printed)."""
    proc = _start(SLOW_START, ["study", str(CONFIGS / "patch.toml"), "--sweep",
                               "interface.interface.mu=0.2,0.4", "--out",
                               str(tmp_path / "w"), "--quiet"], 2)
    assert proc.stdout.readline().strip() == "loading"
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1, stderr
    assert stderr.splitlines()[-1] == ("error: interrupted by SIGTERM during start-up; no "
                                       "step completed"), stderr


# PETSc's start (its stderr is captured for its error report) takes long
SLOW_PETSC_START = """
import sys, time
import petsc4py
real = petsc4py.init
def init(*args, **kwargs):
    print("starting", flush=True)
    time.sleep(3)
    return real(*args, **kwargs)
petsc4py.init = init
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_a_signal_during_petscs_start_prints_its_line(tmp_path):
    """The start-up handler printed its line into the capture of PETSc's start: lost."""
    out = tmp_path / "o"
    proc = _start(SLOW_PETSC_START, ["run", str(CONFIGS / "patch.toml"), "--out", str(out),
                                     "--quiet"], 1)
    assert proc.stdout.readline().strip() == "starting"
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 143, stderr
    assert stderr.splitlines()[-1] == ("error: interrupted by SIGTERM during start-up; no "
                                       "step completed"), stderr
    assert read_summary(out)["status"] == "interrupted"
