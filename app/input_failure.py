"""A `failed` summary.json for bad input found before a run starts.

The config, the `--set` overrides and the command-line checks are read before the run
takes its output folder (app/run.py). Without this, a mistake there (`--set
interface.x.mu='"a"'`, a misspelled key, a run too large for the machine) left no
summary.json at all, or worse, the `completed` summary.json of an earlier run in that
folder, so an unattended run could not be checked afterwards (README "Exit status").
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from petsc4py import PETSc

from app.errors import InputError


def record_input_failure(exc: InputError, folder: Callable[[], Path] | None, config: Path,
                         overrides: list[str]) -> None:
    """Record `exc` in OUT/summary.json as a run that failed before step 1 (status
    `failed`, `error`, `failed_step` 1, no step), as a run does: the folder's lock taken,
    the earlier run's files of this tool removed. folder() gives OUT, created and checked
    (an InputError: not usable); None: no folder to write (a mistyped config path without
    --out creates none). Nothing is written when the folder is not usable or another run
    holds it; `exc` is raised either way."""
    from app.output.provenance import provenance
    from app.output.status import RunGuard
    from app.run import write_summary

    if folder is None:
        raise exc
    try:
        out = folder()
    except InputError:
        raise exc from None
    summary = {"config": str(config), "n_steps": None, "steps": [], "status": "running",
               "provenance": provenance(None, overrides, PETSc.COMM_WORLD.getSize())}
    try:
        with RunGuard(out, summary, write_summary, 1):
            raise exc
    except InputError as got:
        if got is not exc:  # the folder's lock: another run writes there
            raise exc from None
        raise
