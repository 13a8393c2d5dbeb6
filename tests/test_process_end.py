"""The process's end after a completed command (app/exit_sync.py `end_process`): the
atexit handlers, PetscFinalize (-log_view printed), then os._exit past the interpreter's
teardown of its modules, which took 0.4-0.5 s after summary.json, in no phase. A failed
command ends as before."""

from __future__ import annotations

import subprocess
import sys

import pytest
from support import CONFIGS, ROOT, mpi_env, read_summary

HOOK = """
import runpy, sys
class Teardown:
    def __del__(self):
        sys.stderr.write("TEARDOWN\\n")
keep = Teardown()
sys.argv = ["app", *sys.argv[1:]]
runpy.run_module("app", run_name="__main__")
"""
"""The app as `python -m app`, with an object that says so when the interpreter's
teardown frees it."""


def _run(args: list[str], ranks: int) -> subprocess.CompletedProcess:
    head = ["mpiexec", "-n", str(ranks)] if ranks > 1 else []
    return subprocess.run([*head, sys.executable, "-c", HOOK, *args], cwd=ROOT,
                          env=mpi_env(), capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_completed_run_ends_past_the_teardown_with_its_log(tmp_path, ranks):
    out = tmp_path / "o"
    res = _run(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                "-log_view"], ranks)
    assert res.returncode == 0, res.stderr
    assert read_summary(out)["status"] == "completed"
    assert "TEARDOWN" not in res.stderr
    assert res.stdout.count("PETSc Performance Summary") == 1  # printed by PetscFinalize
    assert res.stdout.rstrip().endswith("-" * 41)  # to its last line


def test_a_failed_run_ends_as_before(tmp_path):
    res = _run(["run", str(CONFIGS / "patch.toml"), "--out", str(tmp_path / "o"),
                "--mesh-size", "-1"], 1)
    assert res.returncode == 2 and res.stderr.startswith("error: ")
    assert res.stderr.rstrip().endswith("TEARDOWN")


NO_FINALIZE = """
import petsc4py
start = petsc4py.init
def init(*args, **kwargs):  # PETSc started with the app's options, then _finalize gone
    start(*args, **kwargs)
    from petsc4py import PETSc
    del PETSc._finalize
petsc4py.init = init
""" + HOOK
"""The app with a petsc4py that has no private `_finalize` (a future one may drop it)."""


def test_a_petsc4py_without_its_private_finalize_ends_as_before(tmp_path):
    out = tmp_path / "o"
    res = subprocess.run([sys.executable, "-c", NO_FINALIZE, "run", str(CONFIGS / "patch.toml"),
                          "--out", str(out), "--quiet", "-log_view"], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert "Traceback" not in res.stderr and "AttributeError" not in res.stderr
    assert res.stderr.rstrip().endswith("TEARDOWN")  # the interpreter's own end
    assert read_summary(out)["status"] == "completed"
    assert res.stdout.count("PETSc Performance Summary") == 1  # PetscFinalize ran once


def test_a_profiled_run_ends_through_the_interpreter_with_its_profile(tmp_path):
    """README's `python -m cProfile -s cumtime -m app run ...`: cProfile prints its table
    after the app returns; the fast end (os._exit) left it out, exit 0 and no table."""
    res = subprocess.run([sys.executable, "-m", "cProfile", "-s", "cumtime", "-m", "app",
                          "run", str(CONFIGS / "patch.toml"), "--out", str(tmp_path / "o"),
                          "--quiet"], cwd=ROOT, env=mpi_env(), capture_output=True,
                         text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert "function calls" in res.stdout and "cumulative" in res.stdout
    assert read_summary(tmp_path / "o")["status"] == "completed"
