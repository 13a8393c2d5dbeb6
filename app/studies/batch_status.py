"""OUT/summary.json of a study or a sweep: `completed`, `failed` or `interrupted`, and why.

Each run of a study writes its own summary.json in its folder (OUT/L<level>_<label>,
OUT/run_NNN); this is the study's own, in OUT. Before, a study or sweep that stopped on
bad input (a config or option error, every run failed) left no summary.json in OUT, so an
unattended one could not be checked afterwards (README "Exit status").

`BatchStatus` wraps the command. Bad input found before OUT is taken is recorded as `run`
records it (app/startup/input_failure.py: OUT's lock, another program's summary.json left
alone). `open(cfg)` takes OUT as a run does (lock held until the end, another program's
files refused, an earlier summary.json removed) and writes nothing yet: while the study
runs, OUT has no summary.json, so a job killed outright (SIGKILL) leaves none rather than
a false `running`. On exit the summary says `completed`, `failed` (InputError,
SolveError, PETSc error, write error) or `interrupted` (SIGINT / SIGTERM; on several ranks
through the stop hooks of app/output/status.py, since no rank stops by itself there, and
inside a MUMPS factorization or solve through the C handler of app/hard_stop.py, which
writes this summary after the run's), with `error` = the `error:` line app/cli.py prints.
Until `open`, a signal is the start-up handler's (app/output/startup_signals.py, armed by
app/cli.py with this summary's first keys): it writes `interrupted` and stops at once.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

from petsc4py import PETSc

from app import hard_stop
from app.errors import InputError, SolveError
from app.output import startup_signals, status
from app.output.out_owner import (
    copied_runs,
    earlier_study,
    foreign_files,
    foreign_message,
    planted_links,
)
from app.startup.early_failure import study_head

OUTSIDE_A_STEP = ("interrupted by SIGINT outside a load step; what completed before it is "
                  "written")
"""The error of SIGINT on one rank between a study's runs (app/cli.py prints it too)."""


def clear_earlier_study(out: Path) -> None:
    """Remove an earlier study's files and run folders from OUT (out_owner.earlier_study),
    so that OUT holds this study's results only. In a run's folder only this tool's files
    go (status.STALE and the lock) and the folder when it is then empty: the user's own
    files stay with it; a folder whose lock a running run holds is left whole. What
    cannot be removed stays."""
    files, folders = earlier_study(out)
    for p in files:
        try:
            p.unlink()
        except OSError:
            pass
    for d in folders:
        try:
            lock = status.lock_folder(d)
        except InputError:  # a run writes there now
            continue
        with lock:
            status.clear_files(d)
            (d / status.LOCK_NAME).unlink(missing_ok=True)
        try:
            d.rmdir()
        except OSError:  # the user's files in it
            pass


def kept_line(kept: list[Path]) -> str:
    """The warning for OUT's run folders that an earlier study's clean-up keeps: a study
    run's summary.json that was not written there (out_owner.copied_runs)."""
    names = ", ".join(p.name for p in kept)
    return (f"kept {names} in {kept[0].parent}: a study run's results that no study wrote "
            "there (its summary.json records another folder, or none: copied or moved by "
            "hand, or from a version before the folder was recorded); a study removes "
            "only its own runs' files: move or remove it yourself if it is stale (a run "
            "of this study of the same name replaces its results, as a `run` into that "
            "folder does)")


def removed_links_line(out: Path, removed: list[str]) -> str:
    """The warning for the links under a study's names that it removed from OUT
    (`NAME -> TARGET` each; out_owner.planted_links): a user may have made one on purpose
    (run_000 or mesh_cache on another disk), and it went without a word before."""
    shown = ", ".join(removed[:5]) + (f" and {len(removed) - 5} more" if len(removed) > 5
                                      else "")
    return (f"removed the links {shown} from {out} (their targets are untouched): a study "
            "writes its files, run folders and mesh_cache inside OUT, never through a "
            "link; to put a study on another disk, give --out there")


class BatchStatus:
    """Context manager around a `study` command: its summary.json in OUT on every exit.

    kind: "convergence" or "sweep"; folder(): OUT created and checked (InputError if not
    usable), None when there is no folder to write (a mistyped config without --out)."""

    def __init__(self, kind: str, config: Path, overrides: list[str],
                 folder: Callable[[], Path] | None, launched: float | None = None,
                 started: float | None = None):
        self.kind = kind
        self.launched = launched  # perf_counter at the process's start (None: unknown)
        self.started = started  # perf_counter at PETSc's start-up
        self.config = Path(config)
        self.overrides = list(overrides)
        self.folder = folder
        self.out: Path | None = None
        self.rank = PETSc.COMM_WORLD.getRank()
        self.summary: dict = {}
        self._lock = None
        self._refused = False  # OUT held by another run or program: nothing to write there

    def head(self) -> dict:
        """The keys every study summary starts with (without provenance)."""
        return {**study_head(self.kind, self.config), "status": "running"}

    def open(self, cfg) -> Path:
        """OUT, created, checked and locked (collective): refused when another run writes
        there or it holds another program's summary.json; this tool's earlier files
        removed. cfg: the loaded config (its resolved text goes into the provenance)."""
        from app.output.provenance import provenance
        from app.parallel import collective

        out = self.folder()
        startup_signals.defer()  # a signal from now on: acted on by the runs' guards

        def take() -> None:
            lock = status.lock_folder(out)
            foreign = foreign_files(out, status.STALE)
            if foreign:
                lock.close()
                raise InputError(foreign_message(out, foreign))
            clear_earlier_study(out)
            status.clear_files(out)
            removed = []
            for link in planted_links(out):  # a study's names: not written through
                with contextlib.suppress(OSError):
                    target = os.readlink(link)
                    link.unlink()
                    removed.append(f"{link.name} -> {target}")
            self._lock = lock
            return copied_runs(out), removed

        try:
            kept, removed = collective(take)
        except InputError:  # every rank: no failed summary.json over the holder's
            self._refused = True
            raise
        self.summary = {**self.head(), "provenance": provenance(
            cfg.raw, self.overrides, PETSc.COMM_WORLD.getSize()),
            "timings": shared_start(self.launched, self.started, time.perf_counter())}
        warnings = ([kept_line(kept)] if kept else []) + \
            ([removed_links_line(out, removed)] if removed else [])
        if warnings:
            self.summary["warnings"] = warnings
            if self.rank == 0:
                for line in warnings:
                    print(f"warning: {line}", file=sys.stderr)
        self.out = out
        status.on_stop(self._stopped)
        hard_stop.add_extra(self._hard_stop_text)
        return out

    def completed(self, rows: int, table: str) -> None:
        """The study ended with `rows` rows in OUT/`table` (study.csv or sweep.csv)."""
        self.summary.update(rows=rows, results=table)

    def __enter__(self) -> BatchStatus:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if self.out is None:  # before OUT was taken: as a run's bad input
            if isinstance(exc, InputError | SolveError) and not self._refused:
                from app.startup.input_failure import record_input_failure

                record_input_failure(exc, self.folder, self.config, self.overrides,
                                     head={**self.head()})
            return False
        status.remove_on_stop(self._stopped)
        hard_stop.remove_extra(self._hard_stop_text)
        try:
            error = self._record(exc)
        finally:
            if self._lock is not None:
                self._lock.close()
        if error is not None:
            raise error from None
        return False

    def _record(self, exc: BaseException | None) -> InputError | None:
        """Write the final summary (rank 0); an InputError to raise instead of `exc`."""
        s, raised = self.summary, None
        if exc is None:
            s["status"] = "completed"
        elif isinstance(exc, KeyboardInterrupt | status.RunInterrupted):
            s["status"] = "interrupted"
            s["error"] = OUTSIDE_A_STEP if isinstance(exc, KeyboardInterrupt) else str(exc)
        else:
            s["status"], s["error"] = "failed", reason(exc, self.out)
            if isinstance(exc, OSError):
                raised = InputError(s["error"])
        self._write()
        return raised

    def _stopped(self) -> None:
        """A stop hook (several ranks: the job ends on a signal without raising here)."""
        self.summary["status"] = status.stop_status()  # (`failed`: another rank's failure)
        self.summary["error"] = status.stop_reason() or (
            "interrupted by SIGINT or SIGTERM; what completed before it is written")
        self._write()

    def _hard_stop_text(self, name: str, line: str) -> tuple[Path, bytes, str]:
        """What app/_hard_stop.c writes into OUT/summary.json on `name` inside a long PETSc
        call of a run (rank 0 of several), after the run's own summary: `interrupted`,
        with the run's line (`line`, "error: ...\\n") as the error (no end_time: it is
        prepared when the call starts)."""
        reason = line.removeprefix("error: ").rstrip("\n")
        summary = {**self.summary, "status": "interrupted", "error": reason, "steps": []}
        return self.out / "summary.json", (json.dumps(summary, indent=2) + "\n").encode(), ""

    def _write(self) -> None:
        from app.output.summary import write_summary

        if self.rank != 0:
            return
        self.summary["end_time"] = datetime.datetime.now(datetime.UTC).isoformat(
            timespec="seconds")
        begun = self.launched if self.launched is not None else self.started
        if "timings" in self.summary and begun is not None:
            self.summary["timings"]["total"] = time.perf_counter() - begun
        if not status.write_summary_robust(lambda out, s: write_summary(out / "summary.json",
                                                                        s), self.out,
                                           self.summary):
            print(f"warning: could not update {self.out / 'summary.json'}", file=sys.stderr)


def shared_start(launched: float | None, started: float | None, opened: float) -> dict:
    """The study's process start-up, shared by all its runs (perf_counter seconds: the
    process's start, PETSc's start-up, OUT taken): {"launch": the interpreter, imports,
    PETSc's and MPI's start; "startup": imports, config and option checks, provenance,
    OUT's lock}, seconds, as a `run`'s phases of those names; a part not known is left out.
    A study's runs have neither phase, so their `t_total` is their own phases, from the
    mesh to the output, and this is paid once, not by the first run."""
    out = {}
    if launched is not None and started is not None and launched < started:
        out["launch"] = started - launched
    if started is not None:
        out["startup"] = opened - started
    return out


def shared_start_line(timings: dict) -> str:
    """One line saying how a study's run times are counted, with the shared start-up."""
    known = ", ".join(f"{k} {timings[k]:.2f} s" for k in ("launch", "startup") if k in timings)
    return ("t_total: each run's own phases, from its mesh to its output; the process "
            "start-up that a `run` adds to its total is shared by the study's runs and "
            f"counted once, in the study's summary.json `timings` ({known or 'not known'})")


def reason(exc: BaseException, out: Path) -> str:
    """The one line of a study's failure (as app/cli.py prints it, without `error: `)."""
    if isinstance(exc, PETSc.Error):
        from app.petsc_options import petsc_error_line

        return f"PETSc: {petsc_error_line(exc)}"
    if isinstance(exc, OSError):
        return f"cannot write the study's results into {out}: {status._os_reason(exc)}"
    if isinstance(exc, InputError | SolveError):
        return str(exc)
    return f"{type(exc).__name__}: {exc}"
