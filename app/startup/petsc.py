"""Start PETSc with the command line's PETSc options; a refusal is one line.

PETSc reads some options while it starts (PetscInitialize): `-options_file FILE`,
`-options_file_yaml FILE`, `-options_string_yaml TEXT`, `-prefix_push` / `-prefix_pop`,
`-info FILE`, `-log_trace FILE`, `-history FILE`. A missing file or a malformed value
there made petsc4py's start raise `petsc4py.PETSc.Error: error code 83` as a traceback
after PETSc's own 20-line error report, exit 1, and an unwritable `-history FILE` crashed
PETSc with a segmentation fault (scripts/fuzz_inputs.py found them). Here PETSc's error
output during the start is captured, and a failure becomes one line naming PETSc's own
reason; `-history` is checked before, as PETSc does not survive it.
"""

from __future__ import annotations

import os
import signal
import sys
import tempfile

from app.errors import InputError
from app.user_paths import path_kind


def _history_problem(petsc_args: list[str]) -> str | None:
    """Why `-history FILE` cannot be written (PETSc would crash on it), or None."""
    if "-history" not in petsc_args:
        return None
    i = petsc_args.index("-history")
    name = petsc_args[i + 1] if i + 1 < len(petsc_args) else ""
    if not name or name.startswith("-"):
        return None  # PETSc's default file name in the working folder
    try:
        folder = os.path.dirname(os.path.abspath(name))
        ok = path_kind(folder, "-history") == "dir" and os.access(folder, os.W_OK) \
            and path_kind(name, "-history") in (None, "file")
    except InputError as exc:
        return str(exc)
    return None if ok else f"-history {name}: cannot write that file"


def _reason(captured: str) -> str | None:
    """The first line of PETSc's error report that says what went wrong."""
    skip = ("---", "See ", "Petsc Release", "Configure options", "#", "Try option", "or see")
    for line in captured.splitlines():
        if "PETSC ERROR:" not in line:
            continue
        text = line.split("PETSC ERROR:", 1)[1].strip()
        if text and not text.startswith(skip) and " on a " not in text:
            return text
    return None


def start_petsc(petsc_args: list[str]) -> str | None:
    """Initialise PETSc (petsc4py) with `petsc_args`. Returns None, or the one-line
    reason (without `error: `) why PETSc refused them; then PETSc is not usable and the
    caller exits with status 2."""
    from app.output import startup_signals

    # PETSc opens -history's file on rank 0 only (PetscOpenHistoryFile): rank 0 judges.
    # Before, every rank did: one whose folders differ (a relative name, ranks started in
    # other folders or on other nodes) refused alone, silently, and the job was aborted.
    if startup_signals.launcher_rank() == 0:
        problem = _history_problem(petsc_args)
        if problem:
            return problem
    import petsc4py

    sys.stdout.flush()
    sys.stderr.flush()

    with startup_signals.held():  # its line is not to go into the capture below
        return _start_captured(petsc4py, petsc_args)


def ignore_sigpipe() -> None:
    """Put back Python's SIGPIPE disposition (ignored: a write to a pipe without a reader
    raises BrokenPipeError). PETSc's start (petsc4py starts it with -no_signal_handler,
    PetscPopSignalHandler) resets SIGPIPE to its default, which ends the process at once,
    silently: under mpiexec, rank 0 writing a search's problem into its HiGHS process
    (app/lcp/mip.py) that mpiexec's SIGTERM to the rank's process group had just killed
    died there, 40 ms after that SIGTERM and before its watchdog had written the
    `interrupted` summary or its line (tests/test_stop_sigpipe.py)."""
    try:
        signal.signal(signal.SIGPIPE, signal.SIG_IGN)
    except (ValueError, AttributeError):  # not the main thread; no SIGPIPE (Windows)
        pass


def _start_captured(petsc4py, petsc_args: list[str]) -> str | None:
    """start_petsc with PETSc's error output during the start captured."""
    saved = os.dup(2)
    failed: Exception | None = None
    with tempfile.TemporaryFile() as capture:
        os.dup2(capture.fileno(), 2)
        try:
            petsc4py.init([sys.argv[0]] + petsc_args)
            from petsc4py import PETSc  # noqa: F401  (PETSc starts on this import)
        except Exception as exc:  # petsc4py.PETSc.Error, not importable before the start
            failed = exc
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        capture.seek(0)
        captured = capture.read().decode(errors="replace")
    if failed is None:
        ignore_sigpipe()
        sys.stderr.write(captured)  # anything PETSc printed on a good start
        return None
    reason = _reason(captured) or str(failed)
    return str(InputError(f"PETSc cannot start with the options {' '.join(petsc_args)}: "
                          f"{reason}"))
