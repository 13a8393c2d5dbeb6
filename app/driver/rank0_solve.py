"""Contact work that only rank 0 does (the LCP's set-up and solves), with its failure
shared by every rank.

Rank 0 builds and solves the LCP while the other ranks wait for its answer. A SolveError
or InputError on rank 0 alone (e.g. 'the contact LCP matrix is not finite') used to leave
the other ranks in the next collective: the run hung with `status` at `running` and no
line. `on_rank0_solve` broadcasts the outcome, so every rank raises it at the same place.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from app.parallel import rank0_call


def on_rank0_solve(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """fn(*args, **kwargs) on rank 0 (its result there, None elsewhere); an InputError or
    SolveError it raises is raised on every rank (`app.parallel.rank0_call`)."""
    return rank0_call(fn, *args, share_result=False, **kwargs)
