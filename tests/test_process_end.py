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
import sys
class Teardown:
    def __del__(self):
        sys.stderr.write("TEARDOWN\\n")
keep = Teardown()
"""
"""A sitecustomize module: an object that says so when the interpreter's teardown frees
it. The app itself runs as `python -m app` (the fast end is for that only: run by other
Python code, as the hook once ran it through runpy, it ends through the interpreter)."""


def _env(tmp_path, hook: str = HOOK) -> dict[str, str]:
    """mpi_env with `hook` as sitecustomize, first on the path."""
    site = tmp_path / "site"
    site.mkdir(exist_ok=True)
    (site / "sitecustomize.py").write_text(hook)
    env = mpi_env()
    env["PYTHONPATH"] = f"{site}:{env['PYTHONPATH']}"
    return env


def _run(args: list[str], ranks: int, env: dict[str, str]) -> subprocess.CompletedProcess:
    head = ["mpiexec", "-n", str(ranks)] if ranks > 1 else []
    return subprocess.run([*head, sys.executable, "-m", "app", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("ranks", [1, 2])
def test_a_completed_run_ends_past_the_teardown_with_its_log(tmp_path, ranks):
    out = tmp_path / "o"
    res = _run(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                "-log_view"], ranks, _env(tmp_path))
    assert res.returncode == 0, res.stderr
    assert read_summary(out)["status"] == "completed"
    assert "TEARDOWN" not in res.stderr
    assert res.stdout.count("PETSc Performance Summary") == 1  # printed by PetscFinalize
    assert res.stdout.rstrip().endswith("-" * 41)  # to its last line


def test_a_failed_run_ends_as_before(tmp_path):
    res = _run(["run", str(CONFIGS / "patch.toml"), "--out", str(tmp_path / "o"),
                "--mesh-size", "-1"], 1, _env(tmp_path))
    assert res.returncode == 2 and res.stderr.startswith("error: ")
    assert res.stderr.rstrip().endswith("TEARDOWN")


NO_FINALIZE = HOOK + """
import petsc4py
start = petsc4py.init
def init(*args, **kwargs):  # PETSc started with the app's options, then _finalize gone
    start(*args, **kwargs)
    from petsc4py import PETSc
    del PETSc._finalize
petsc4py.init = init
"""
"""The app with a petsc4py that has no private `_finalize` (a future one may drop it)."""


def test_a_petsc4py_without_its_private_finalize_ends_as_before(tmp_path):
    out = tmp_path / "o"
    res = _run(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                "-log_view"], 1, _env(tmp_path, NO_FINALIZE))
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


WRAPPER = """
import runpy, sys
sys.argv = ["app", *sys.argv[1:]]
try:
    runpy.run_module("app", run_name="__main__", alter_sys=True)
finally:  # as memray's report, or a timing hook's
    print("REPORT AFTER THE APP", file=sys.stderr, flush=True)
"""
"""A program that runs the app and writes after it returns."""


def test_a_program_that_runs_the_app_writes_after_it(tmp_path):
    """The fast end (os._exit) passed the `finally` of whatever ran the app through runpy:
    memray's report or a hook's lines were lost from a completed run, exit 0."""
    out = tmp_path / "o"
    res = subprocess.run([sys.executable, "-c", WRAPPER, "run", str(CONFIGS / "patch.toml"),
                          "--out", str(out), "--quiet", "--mesh-size", "0.5"], cwd=ROOT,
                         env=_env(tmp_path), capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    assert res.stderr.splitlines()[-2:] == ["REPORT AFTER THE APP", "TEARDOWN"], res.stderr
    assert read_summary(out)["status"] == "completed"
