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
"""

from __future__ import annotations

import os
import sys
import time
import traceback

RANK0_SECONDS = 10.0
"""How long rank 0 waits for the others at a failed end (it has printed its line and
written summary.json: ending the others then loses nothing)."""

OTHER_SECONDS = 30.0
"""How long another rank waits for rank 0, which may still be writing summary.json or a
study's tables."""

_STATE: dict = {"comm": None}


def arm() -> None:
    """After PETSc started, on every rank (collective): the communicator of the end."""
    from petsc4py import PETSc

    comm = PETSc.COMM_WORLD.tompi4py()
    _STATE["comm"] = comm.Dup() if comm.size > 1 else None


def leave_if_alone(code: int, message: str | None = None, with_traceback: bool = False,
                   seconds: float | None = None) -> None:
    """At a failed end (exit status `code`): return once every rank is here too; else,
    after RANK0_SECONDS (rank 0) or OTHER_SECONDS, print what this rank knows and exit
    with `code` at once. message: this rank's `error:` line (printed by a rank other than
    0 only); with_traceback: print the exception being handled."""
    comm = _STATE["comm"]
    if comm is None:
        return
    limit = seconds if seconds is not None else (RANK0_SECONDS if comm.rank == 0
                                                  else OTHER_SECONDS)
    request = comm.Ibarrier()
    deadline = time.monotonic() + limit
    while not request.Test():
        if time.monotonic() > deadline:
            if with_traceback:
                traceback.print_exc()
            if message is not None and comm.rank != 0:
                print(f"{message} (rank {comm.rank}; the other ranks did not fail)",
                      file=sys.stderr)
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code)
        time.sleep(0.005)
