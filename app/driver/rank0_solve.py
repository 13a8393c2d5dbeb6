"""Contact work that only rank 0 does (the LCP's set-up and solves), with its failure
shared by every rank.

Rank 0 builds and solves the LCP while the other ranks wait for its answer. A SolveError
or InputError on rank 0 alone (e.g. 'the contact LCP matrix is not finite') used to leave
the other ranks in the next collective: the run hung with `status` at `running` and no
line. `on_rank0_solve` broadcasts the outcome, so every rank raises it at the same place.
"""

from __future__ import annotations

from petsc4py import PETSc

from app.errors import InputError, SolveError


def on_rank0_solve(fn, *args, **kwargs):
    """fn(*args, **kwargs) on rank 0 (its result there, None elsewhere); an InputError or
    SolveError it raises is raised on every rank."""
    comm = PETSc.COMM_WORLD.tompi4py()
    result, error = None, None
    if comm.rank == 0:
        try:
            result = fn(*args, **kwargs)
        except (InputError, SolveError) as exc:
            error = exc
    if comm.size > 1:
        shared = comm.bcast(error, root=0)
        error = error if error is not None else shared
    if error is not None:
        raise error
    return result
