"""app/startup/petsc.py: PETSc options that PETSc refuses while it starts are one line.

Before: `-options_file /nonexistent` (and -options_file_yaml, -prefix_pop, -info FILE,
-log_trace FILE with a folder that does not exist) ended in PETSc's 20-line report and a
`petsc4py.PETSc.Error: error code 83` traceback, exit 1; `-history /proc/x/y` in a
segmentation fault (found by scripts/fuzz_inputs.py)."""

from __future__ import annotations

import pytest
from support import CONFIGS, run_cli

from app.startup.petsc import _history_problem, _reason


def test_reason_is_the_first_line_that_says_what_went_wrong():
    report = ("[0]PETSC ERROR: --------------------- Error Message -----------\n"
              "[0]PETSC ERROR: Unable to open options file /nonexistent\n"
              "[0]PETSC ERROR: See https://petsc.org/release/faq/ for trouble shooting.\n"
              "[0]PETSC ERROR: #1 PetscOptionsInsertFilePetsc() at options.c:553\n")
    assert _reason(report) == "Unable to open options file /nonexistent"
    assert _reason("nothing from PETSc") is None


def test_history_file_is_checked(tmp_path):
    assert _history_problem(["-ksp_type", "cg"]) is None
    assert _history_problem(["-history"]) is None  # PETSc's default name
    assert _history_problem(["-history", str(tmp_path / "h.txt")]) is None
    assert "cannot write" in _history_problem(["-history", "/proc/x/y"])
    assert "cannot write" in _history_problem(["-history", str(tmp_path)])


@pytest.mark.parametrize("opts, reason", [
    (["-options_file", "/nonexistent/opts"], "Unable to open options file"),
    (["-prefix_pop"], "PETSc cannot start with the options -prefix_pop: "),
    (["-history", "/proc/x/y"], "-history /proc/x/y: cannot write that file"),
])
def test_refused_start_is_one_line(tmp_path, opts, reason):
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(tmp_path / "o"),
                   "--quiet", *opts])
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and reason in lines[0], lines
