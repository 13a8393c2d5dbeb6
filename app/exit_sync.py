"""The end of a failed job on several ranks: leave when a rank never comes to the end.

A rank that fails alone (an exception that only it raises: a MemoryError in its part of
the assembly or the fields, a bug on one rank) used to leave the others waiting in their
next collective and itself waiting for them in MPI_Finalize: the job hung until mpiexec
was killed. Rank 0's own calls share their failures (`app.parallel.rank0_call`); this is
the net under everything else. On a failure every rank meets the others in a barrier of
a communicator of its own; a rank that waits longer than its limit there exits at once
(os._exit, past MPI_Finalize), after printing its message if it is not rank 0 (which
printed its own), and mpiexec then ends the ranks that wait in a collective. When every
rank fails alike (any input error) they all meet at once and end as before.

The reason travels to rank 0 through a note in the run's OUT (`note_in`): a rank other
than 0 at a failed end writes its one line there before it waits, so that rank 0, stuck
in a collective until mpiexec's SIGTERM (sent once that rank has exited), records the job
as `failed` with that line (`peer_failure`, app/output/status.py) instead of `interrupted
by SIGTERM`. No MPI call is added (the ranks run MPI_THREAD_FUNNELED: rank 0's watchdog
thread may not call MPI while its main thread waits in a collective); a rank that cannot
see OUT (no shared file system) leaves no note, and rank 0 records the signal as before.
"""

from __future__ import annotations

import json
import os
import sys
import time
import traceback
from pathlib import Path

RANK0_SECONDS = 10.0
"""How long rank 0 waits for the others at a failed end (it has printed its line and
written summary.json: ending the others then loses nothing)."""

OTHER_SECONDS = 30.0
"""How long another rank waits for rank 0, which may still be writing summary.json or a
study's tables."""

NOTE_NAME = ".failed_rank.json"
"""The note of a rank that failed alone, in the run's OUT (a hidden file, as OUT/.lock)."""

_STATE: dict = {"comm": None, "note": None, "meet": None, "alone": False, "token": ""}


def arm() -> None:
    """After PETSc started, on every rank (collective): the communicators of the end and
    of `failed_together`."""
    from petsc4py import PETSc

    comm = PETSc.COMM_WORLD.tompi4py()
    _STATE["comm"] = comm.Dup() if comm.size > 1 else None
    _STATE["meet"] = comm.Dup() if comm.size > 1 else None


def failed_together() -> bool:
    """After a run failed, in a batch that goes on past a failed run (a sweep): whether
    every rank failed it too (they meet in a barrier of a communicator of their own within
    OTHER_SECONDS; at once when all fail alike, as for a config a check rejects). False:
    this rank failed alone (a MemoryError in its share of the work; the others wait in a
    collective of the run): the batch must end, and its failed end then leaves at once
    (`leave_if_alone`). Before, the sweep went on to its next run and the job hung."""
    comm = _STATE["meet"]
    if comm is None:
        return True
    request = comm.Ibarrier()
    deadline = time.monotonic() + OTHER_SECONDS
    while not request.Test():
        if time.monotonic() > deadline:
            _STATE["alone"] = True
            return False
        time.sleep(0.005)
    return True


def note_in(folder: Path, rank: int, token: str = "") -> None:
    """Every rank, as a run takes its OUT (rank 0 holding OUT's lock, before the others go
    on): the note of a rank failing alone goes to OUT; rank 0 removes an earlier one.
    token: the run's own (rank 0 makes it, every rank gets it): a note carries it, and one
    without it is not this run's (a rank of an earlier job that outlived it can write its
    note after rank 0 removed the old one)."""
    note = Path(folder) / NOTE_NAME
    _STATE["note"] = note
    _STATE["token"] = token
    if rank == 0:
        try:
            note.unlink(missing_ok=True)
        except OSError:
            pass


def peer_failure() -> dict | None:
    """Rank 0, as a signal ends the job: the note of a rank that failed alone in this run
    ({"rank", "code", "error": its line without `error: `, "printed": whether that rank
    printed it}), taken out of OUT; or None."""
    note = _STATE["note"]
    if note is None or _STATE["comm"] is None:
        return None
    try:
        data = json.loads(note.read_text())
        note.unlink()
    except (OSError, ValueError):
        return None
    ok = isinstance(data, dict) and isinstance(data.get("error"), str) and \
        data.get("run") == _STATE["token"]
    return data if ok and data.get("code") in (1, 2) else None


def _leave_note(rank: int, code: int, error: str, printed: bool) -> bool:
    """Write this rank's note (through a rename); whether it was written."""
    note = _STATE["note"]
    if note is None:
        return False
    tmp = note.with_name(f"{note.name}.{rank}.tmp")
    text = json.dumps({"rank": rank, "code": code, "error": error, "printed": printed,
                       "run": _STATE["token"]})
    try:  # a new file, never through a link planted under its name (O_EXCL, O_NOFOLLOW)
        tmp.unlink(missing_ok=True)
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
        with os.fdopen(fd, "w") as fh:
            fh.write(text)
        os.replace(tmp, note)
    except OSError:
        return False
    return True


def _own_line(comm, message: str | None, with_traceback: bool) -> str | None:
    """What a rank other than 0 failed with, for its note: its `error:` line (without the
    prefix) or the exception being handled, and which rank it is."""
    if comm.rank == 0:
        return None
    if message is None and with_traceback and (exc := sys.exc_info()[1]) is not None:
        message = f"error: {type(exc).__name__}: {exc}"
    if message is None:
        return None
    return f"{message.removeprefix('error: ')} (rank {comm.rank}; the other ranks did not fail)"


def leave_if_alone(code: int, message: str | None = None, with_traceback: bool = False,
                   seconds: float | None = None) -> None:
    """At a failed end (exit status `code`): return once every rank is here too; else,
    after RANK0_SECONDS (rank 0) or OTHER_SECONDS, print what this rank knows and exit
    with `code` at once. message: this rank's `error:` line (printed by a rank other than
    0 only); with_traceback: print the exception being handled. A rank other than 0 first
    leaves its note for rank 0 (`note_in`); rank 0 removes it once every rank is here."""
    comm = _STATE["comm"]
    if comm is None:
        return
    limit = seconds if seconds is not None else (RANK0_SECONDS if comm.rank == 0
                                                  else OTHER_SECONDS)
    if _STATE["alone"]:  # it waited for the others already (`failed_together`)
        limit = 0.0
    line = _own_line(comm, message, with_traceback)
    noted = line is not None and _leave_note(comm.rank, code, line, False)
    request = comm.Ibarrier()  # (after the note: rank 0 cannot pass it before the note)
    deadline = time.monotonic() + limit
    while not request.Test():
        if time.monotonic() > deadline:
            if with_traceback:
                traceback.print_exc()
            if message is not None and line is not None:
                print(f"error: {line}", file=sys.stderr)
            sys.stdout.flush()
            sys.stderr.flush()
            if noted:  # rank 0 need not print it again
                _leave_note(comm.rank, code, line, True)
            os._exit(code)
        time.sleep(0.005)
    if comm.rank == 0 and _STATE["note"] is not None:  # every rank failed: no peer's note
        try:
            _STATE["note"].unlink(missing_ok=True)
        except OSError:
            pass


def _run_by_other_code(frame) -> bool:
    """Whether Python code other than runpy's is below `frame` (app/__main__'s): a
    program that ran the app (runpy.run_module or exec from memray, coverage, a hook) and
    may go on after it returns, to write its report in a `finally` or after the call.
    `python -m app` has only runpy's frames there."""
    import runpy

    below = frame.f_back
    while below is not None:
        if below.f_globals is not vars(runpy):  # (runpy is frozen: no file name to test)
            return True
        below = below.f_back
    return False


def end_process(code: int) -> None:
    """The process's end after a command returned 0 (app/__main__.py only; `main` called
    in a process that goes on, as the tests do, never comes here): the atexit handlers
    (petsc4py's _pre_finalize among them), PetscFinalize (-log_view, MPI_Finalize, with
    late_signals' handler re-armed inside it as before), C's and Python's output flushed,
    then os._exit(0). That skips the interpreter's teardown of its ~860 modules: 0.4-0.5 s
    after every run on this machine, after summary.json, in no phase (README "Time
    outside any phase"). Any other status, PETSc not started or already finalized, a
    petsc4py without `_finalize`, a profiler or tracer at work (`python -m cProfile -m
    app ...`, trace, pdb: they report after the app returns), or the app run by other
    Python code (`_run_by_other_code`: memray, a hook that writes in a `finally` after
    `runpy.run_module`; before, their output after the app was lost): returns, and the
    interpreter ends as before.

    `PETSc._finalize` is private, but petsc4py has no public PetscFinalize, and it runs
    the C `finalize` that petsc4py registers with Py_AtExit for the interpreter's end:
    the same code, only before the teardown instead of after it. A petsc4py that
    drops it is checked for before anything is run (tests/test_process_end.py)."""
    petsc = sys.modules.get("petsc4py.PETSc")
    if code != 0 or petsc is None or not petsc.Sys.isInitialized() or petsc.Sys.isFinalized():
        return
    finalize = getattr(petsc, "_finalize", None)
    if not callable(finalize) or sys.getprofile() is not None or sys.gettrace() is not None \
            or _run_by_other_code(sys._getframe(1)):
        return
    import atexit
    import ctypes

    sys.stdout.flush()
    sys.stderr.flush()
    atexit._run_exitfuncs()
    finalize()
    ctypes.CDLL(None).fflush(None)  # PETSc's C stdio (-log_view on a pipe)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)
