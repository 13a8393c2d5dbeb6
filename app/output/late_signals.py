"""SIGINT / SIGTERM outside every run's guard, and at the job's end.

Open MPI's mpiexec (4.1) does not pass a Ctrl-C on: it sends the ranks SIGCONT at once,
SIGTERM 1 s later and SIGKILL 1 s after that, and from the Ctrl-C on it no longer
completes MPI_Finalize's closing exchange, so a rank that reaches MPI_Finalize after
the signal waits there (in C, where no Python handler runs) until it is killed
(README "Exit status"). Two gaps ended a job that way with mpiexec's exit 1 and no line:

- Python code outside every guard after the first run (rank 0 drawing a sweep's or a
  study's plots, a run's closing summary): SIGTERM had its default action, death with
  nothing said. `arm_outside()` makes it raise RunInterrupted there, as SIGINT raises
  KeyboardInterrupt: cli.main prints `error: interrupted by SIGTERM outside a load step;
  what completed before it is written` (exit 143).
- the job's end, once the command has returned (its outputs written, its line printed):
  Python's finalization, PetscFinalize, MPI_Finalize. `arm_end(code)` installs the C
  handler of app/_hard_stop.c without a file to write: rank 0 prints that the work had
  completed and exits with 130 / 143; the other ranks ignore it and wait for mpiexec's
  SIGKILL, which mpiexec sends every rank as soon as one rank has ended (a rank 1 that
  ended first got rank 0 killed before it said anything). PetscFinalize puts SIGTERM
  back to its default (PetscPopSignalHandler) just before it calls MPI_Finalize, which
  is why a handler armed once did not help; a function registered with
  PetscRegisterFinalize installs it again in between. On several ranks rank 0 exits at
  once after its own interrupt line (`leave`), as MPI_Finalize would only wait.
"""

from __future__ import annotations

import os
import signal
import sys

from petsc4py import PETSc

from app import hard_stop
from app.output import startup_signals
from app.output.status import EXIT_SIGNAL, RunInterrupted, unacted_signal

OUTSIDE = "interrupted by {} outside a load step; what completed before it is written"
"""The line of a signal between or after a command's runs (cli.main prints it)."""
ENDING = ("error: interrupted by {} as the job was ending, after its work completed; "
          "every output is written\n")
"""Rank 0's line for a signal after the command returned 0."""


_SEEN: list[str] = []
"""Signals the handlers below raised for: an exception raised inside a weakref callback
or a __del__ (a garbage collection while matplotlib draws) is printed as `Exception
ignored` and lost, and the job went on to its end, where mpiexec killed it silently."""


def _outside(signum, frame):
    name = signal.Signals(signum).name
    _SEEN.append(name)
    if name == "SIGINT":
        raise KeyboardInterrupt
    raise RunInterrupted(name, OUTSIDE.format(name))


def arm_outside() -> None:
    """SIGTERM outside every guard raises RunInterrupted, SIGINT KeyboardInterrupt (the
    handlers the guards and the start-up handler pass signals on to once a run's guard has
    ended), and both are noted for `arm_end`."""
    startup_signals.set_original(signal.SIGINT, _outside)
    startup_signals.set_original(signal.SIGTERM, _outside)


def arm_end(code: int) -> None:
    """From the command's return to the process's exit (cli.main, `code` its exit
    status): a signal prints ENDING (rank 0, code 0) and exits with 130 / 143."""
    rank = PETSc.COMM_WORLD.getRank()
    lines = [ENDING.format(name) if rank == 0 and code == 0 else ""
             for name in ("SIGINT", "SIGTERM")]
    try:
        # Python's own handlers run in Python code only, and its finalization would put
        # the defaults back over the C handler for signals it handles
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
    except ValueError:  # not the main thread (tests calling main in a thread)
        return
    # a rank other than 0 stays: mpiexec kills every rank as soon as one has ended, and
    # rank 0 is to print its line first
    if hard_stop.arm_exit(*lines, stay=rank != 0):
        _rearm_in_petsc_finalize()
    else:  # not built: the same, in Python code only
        def stop(signum, frame):
            if rank != 0:
                return
            sys.stderr.write(lines[signum == signal.SIGTERM])
            sys.stderr.flush()
            os._exit(EXIT_SIGNAL[signal.Signals(signum).name])

        signal.signal(signal.SIGINT, stop)
        signal.signal(signal.SIGTERM, stop)
    # a signal noted inside a guard and never acted on (it came while the last step was
    # written), or whose exception was lost (_SEEN): act on it now
    pending = unacted_signal() or (_SEEN[0] if _SEEN else None)
    if code == 0 and pending is not None:
        signal.raise_signal(getattr(signal, pending))


def _rearm_in_petsc_finalize() -> None:
    """PetscFinalize (at the interpreter's exit) puts SIGTERM back to its default before
    it calls MPI_Finalize, where the ranks wait: have it install the C handler again in
    between (PetscRegisterFinalize functions run after that reset, before MPI_Finalize)."""
    import ctypes

    from app.petsc_lib import load_petsc

    petsc, address = load_petsc(), hard_stop.rearm_address()
    if petsc is None or address is None:
        return
    petsc.PetscRegisterFinalize.argtypes = [ctypes.c_void_p]
    petsc.PetscRegisterFinalize.restype = ctypes.c_int
    petsc.PetscRegisterFinalize(address)


def leave(code: int) -> None:
    """Rank 0 stopped by a signal (code 130 / 143, its line printed) exits here: on
    several ranks mpiexec is ending the job and MPI_Finalize would only wait for its
    SIGKILL (the other ranks wait for it: mpiexec ends them once rank 0 has ended); on
    one, Python ended some of these with -2 (SIGINT) instead of 130 (2 of 40 trials at
    the end of a sweep), the line printed."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        return
    if code in EXIT_SIGNAL.values() and PETSc.COMM_WORLD.getRank() == 0:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
