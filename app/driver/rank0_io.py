"""File writes that only rank 0 does, with their failure shared by every rank.

Rank 0 writes the output files; the other ranks go straight on to the next collective.
An OSError on rank 0 alone (a full disk) used to leave the ranks in different
collectives: rank 0 in a barrier on its way out, the others in the next step's
reductions, and the run hung with `status` at `running`. `on_rank0` broadcasts the
outcome, so every rank raises the error at the same place.
"""

from __future__ import annotations

from petsc4py import PETSc

from app.parallel import PeerFailure, peer_failure


def on_rank0(fn, *args, **kwargs):
    """fn(*args, **kwargs) on rank 0 (its result there, None elsewhere); an OSError it
    raises is raised on every rank (the original on rank 0, errno and text elsewhere), any
    other exception on rank 0 and a PeerFailure (app/parallel.py) on the others."""
    comm = PETSc.COMM_WORLD.tompi4py()
    result, error, other = None, None, None
    if comm.rank == 0:
        try:
            result = fn(*args, **kwargs)
        except OSError as exc:
            error = exc
        except Exception as exc:  # noqa: BLE001 - shared so that no rank waits for it
            error, other = exc, peer_failure(exc)
    if comm.size > 1:
        shared = comm.bcast(None if error is None else (
            other if other is not None else (error.errno, str(error))), root=0)
        if isinstance(shared, PeerFailure) and error is None:
            error = shared
        elif shared is not None and error is None:
            error = OSError(shared[0], shared[1]) if shared[0] else OSError(shared[1])
    if error is not None:
        raise error
    return result
