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
                         overrides: list[str], head: dict | None = None) -> None:
    """Record `exc` in OUT/summary.json as a run that failed before step 1 (status
    `failed`, `error`, `failed_step` 1, no step), as a run does: the folder's lock taken,
    the earlier run's files of this tool removed. folder() gives OUT, created and checked
    (an InputError: not usable); None: no folder to write (a mistyped config path without
    --out creates none). Nothing is written when the folder is not usable or another run
    holds it; `exc` is raised either way, with why nothing was written when OUT is not
    usable or another run or program holds it. head: the summary's first keys instead of
    a run's (a study's, app/studies/batch_status.py: no steps, so no failed_step)."""
    from app.output.provenance import provenance
    from app.output.status import RunGuard
    from app.run import write_summary

    if folder is None:
        raise exc
    try:
        out = folder()
    except InputError as unusable:
        raise _with_reason(exc, unusable) from None
    summary = {**(head or {"config": str(config), "n_steps": None, "steps": [],
                           "status": "running"}),
               "provenance": provenance(None, overrides, PETSc.COMM_WORLD.getSize())}
    try:
        with RunGuard(out, summary, write_summary, 1):
            raise exc
    except InputError as got:
        if got is not exc:  # the folder's lock (another run), another program's files
            raise _with_reason(exc, got) from None
        raise


def _with_reason(exc: InputError, unwritten: InputError) -> InputError:
    """`exc`, and why no summary.json records it (`unwritten`'s message) when that is
    another error than `exc` (a bad --out is its own reason)."""
    if str(unwritten) == str(exc):
        return exc
    return InputError(f"{exc}; no summary.json written: {unwritten}")
