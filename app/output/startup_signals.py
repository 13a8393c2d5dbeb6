"""SIGINT / SIGTERM before a run's guard exists: the start-up phase.

Between the process start and `RunGuard.__enter__` (the imports, MPI's start, the config
and size checks: 0.3-2 s) Python's default handlers were in force: SIGTERM, which
Open MPI's mpiexec sends every rank on Ctrl-C, killed the ranks with nothing written, so
an earlier run's `completed` summary.json and step files stayed in OUT as if they were
this run's; and a signal between the guard's clean-up and its first summary.json left
only summary.json.tmp (README "Exit status").

`arm(None, "", act=False)` (app/__main__.py, before the modules load) records a signal;
`arm(out, config)` (cli.main, right after the command line is parsed; stdlib only)
installs a handler that stops at once, also for a signal recorded before: rank 0 takes
OUT's lock (when no other run holds it), removes this tool's files of an earlier run,
writes an `interrupted` summary.json (temporary file and rename) and prints the line;
every rank exits with 130 / 143.
`defer()` (the guard's entry) turns it into a recorder, and `finish()` (once the guard's
own handlers are armed: a run's, or a study's BatchGuard) hands the recorded signal to
the guard; from then on it passes signals on to the handlers from before `arm` (a study's
guard may have saved it).
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import signal
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from app.output.out_owner import UnsafeLock, foreign_files, foreign_message, open_lock

STALE = re.compile(r"^(step_\d{4,}\.h5|results\.xdmf|contact\.xdmf|mesh\.h5|summary\.json)"
                   r"(\.tmp)?$")
"""Files this tool writes into OUT (and their temporary names)."""
EXIT_SIGNAL = {"SIGINT": 130, "SIGTERM": 143}
LOCK_NAME = ".lock"

_STATE: dict = {"mode": "off", "pending": None, "originals": None, "out": None,
                "config": None, "head": None, "launched": None, "started": None}
"""mode: off (pass signals on), record, act (stop at once) or stopping; launched, started:
perf_counter at the process's and at PETSc's start (`set_clock`), for the timings."""


def set_clock(launched: float | None = None, started: float | None = None) -> None:
    """The process's start and PETSc's start-up (perf_counter seconds, None: not known or
    not yet): a stop here writes `timings` with the run's `launch` and `startup` phases."""
    if launched is not None:
        _STATE["launched"] = launched
    if started is not None:
        _STATE["started"] = started


def stop_timings() -> dict:
    """`timings` (the seconds so far of `launch` and `startup`, and `total`) and
    `stopped_in_phase` of a stop during start-up; {} when neither start is known."""
    now = time.perf_counter()
    launched, started = _STATE["launched"], _STATE["started"]
    timings: dict[str, float] = {}
    if started is not None:
        if launched is not None and launched < started:
            timings["launch"] = started - launched
        timings["startup"] = now - started
    elif launched is not None:
        timings["launch"] = now - launched
    if not timings:
        return {}
    origin = min(t for t in (launched, started) if t is not None)
    timings["total"] = now - origin
    return {"timings": timings, "stopped_in_phase": "startup" if started else "launch"}


RANK0_FIRST_SECONDS = 2.0
"""How long a rank other than 0 waits before it exits on a signal: Open MPI's mpiexec
kills every rank as soon as one has ended, and a rank 1 that ended first got rank 0
killed while it wrote its summary or before it printed its line (mpiexec sends the
SIGTERM 1 s after a Ctrl-C and SIGKILL 1 s after that in any case)."""


def exit_after_rank0(code: int) -> None:
    """os._exit(code); on a rank other than 0 after RANK0_FIRST_SECONDS (see there)."""
    if launcher_rank() != 0:
        time.sleep(RANK0_FIRST_SECONDS)
    os._exit(code)


def launcher_rank() -> int:
    """This process's rank as the MPI launcher set it (before MPI is started); 0 alone."""
    for key in ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"):
        if key in os.environ:
            try:
                return int(os.environ[key])
            except ValueError:
                pass
    return 0


def arm(out: Path | None, config: str, act: bool = True, head: dict | None = None) -> None:
    """Install the start-up handler for SIGINT and SIGTERM. out: the run's or study's
    folder (None: write nothing); act False: only record (the imports, app/__main__.py);
    head: the summary's first keys (default a run's; a study's, app/studies/batch_status.py, which
    defers once it takes OUT)."""
    pending = _STATE["pending"] if _STATE["mode"] == "record" else None
    _STATE.update(mode="act" if act else "record", pending=pending, out=out, config=config,
                  head=head)
    try:
        current = (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM))
        if current != (_handler, _handler):  # (since app/__main__.py: keep the first ones)
            _STATE["originals"] = current
        signal.signal(signal.SIGINT, _handler)
        signal.signal(signal.SIGTERM, _handler)
    except ValueError:  # not the main thread (tests calling main in a thread)
        _STATE["mode"] = "off"
        return
    if act and pending is not None:
        _stop(pending)


@contextmanager
def held() -> Iterator[None]:
    """Record a signal in this block and act on it after (PETSc's start, whose stderr is
    captured: the line printed there was lost and the job ended with no line)."""
    acting = _STATE["mode"] == "act"
    if acting:
        _STATE["mode"] = "record"
    try:
        yield
    finally:
        if acting and _STATE["mode"] == "record":
            _STATE["mode"] = "act"
            if _STATE["pending"] is not None:
                _stop(_STATE["pending"])


def defer() -> None:
    """From now on only record (the guard writes its first summary.json)."""
    if _STATE["mode"] == "act":
        _STATE["mode"] = "record"


def finish() -> str | None:
    """The signal recorded since `arm` (None: none, or finished already). From now on the
    handler passes every signal on to the handler that was there before `arm`."""
    pending = _STATE["pending"] if _STATE["mode"] != "off" else None
    _STATE.update(mode="off", pending=None)
    return pending


def unwrap(signum: int, handler: Any) -> Any:
    """`handler`, or the handler from before `arm` if `handler` is the start-up one (what a
    guard puts back when it ends)."""
    if handler is _handler and _STATE["originals"] is not None:
        return _STATE["originals"][0 if signum == signal.SIGINT else 1]
    return handler


def set_original(signum: int, handler: Any) -> None:
    """Pass `signum` on to `handler` instead of the handler from before `arm` (what the
    guards put back when they end: app/output/late_signals.py)."""
    if _STATE["originals"] is not None:
        originals = list(_STATE["originals"])
        originals[0 if signum == signal.SIGINT else 1] = handler
        _STATE["originals"] = tuple(originals)


def restore() -> None:
    """Put back the handlers from before `arm` where the start-up one is still installed
    (the command ended, with or without a run)."""
    finish()
    try:
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, unwrap(signum, signal.getsignal(signum)))
    except ValueError:
        pass


def _handler(signum, frame) -> None:
    name = signal.Signals(signum).name
    if _STATE["mode"] == "off":  # finished: as the handler from before `arm`
        original = unwrap(signum, _handler)
        if callable(original) and original is not _handler:
            return original(signum, frame)
        if original != signal.SIG_IGN:
            signal.signal(signum, signal.SIG_DFL)
            signal.raise_signal(signum)
        return None
    if _STATE["mode"] != "act":
        _STATE["pending"] = _STATE["pending"] or name
        return None
    _stop(name)
    return None


def _stop(name: str) -> None:
    """Record `interrupted` (rank 0) and exit: the start-up handler's action."""
    _STATE["mode"] = "stopping"  # a second signal while this one is handled: recorded
    reason = f"interrupted by {name} during start-up; no step completed"
    if launcher_rank() == 0:
        if _STATE["out"] is not None:
            _record(Path(_STATE["out"]), reason, head=_STATE["head"], more=stop_timings())
        print(f"error: {reason}", file=sys.stderr, flush=True)
    exit_after_rank0(EXIT_SIGNAL[name])


def _record(out: Path, reason: str, status: str = "interrupted",
            head: dict | None = None, more: dict | None = None) -> str | None:
    """With OUT's lock (skipped when another run holds it or OUT is not there): remove the
    earlier run's files of this tool, write a summary.json with `status` and `reason`
    (head: its first keys, default a run's; more: keys after them, e.g. `timings`).
    Returns None, or why nothing was written."""
    try:
        out.mkdir(parents=True, exist_ok=True)  # as the run would have
        fh = open_lock(out / LOCK_NAME)
    except UnsafeLock as exc:  # not followed: nothing written
        return str(exc)
    except OSError as exc:  # not usable: the run would have stopped there too
        return f"--out {out}: cannot write there ({exc.strerror or exc})"
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        foreign = foreign_files(out, STALE)
        if foreign:  # the user's files under this tool's names: untouched
            return foreign_message(out, foreign)
        for p in out.iterdir():
            if STALE.match(p.name) and (p.is_file() or p.is_symlink()):
                p.unlink(missing_ok=True)
        text = json.dumps({**(head or {"config": _STATE["config"], "n_steps": None,
                                       "steps": []}),
                           **(more or {}), "status": status, "error": reason},
                          indent=2) + "\n"
        tmp = out / "summary.json.tmp"
        tmp.write_text(text)
        os.replace(tmp, out / "summary.json")
    except OSError as exc:  # another run writes there, or a full disk: leave it alone
        return (f"--out {out}: another run is writing into this folder" if
                isinstance(exc, BlockingIOError) else f"--out {out}: {exc.strerror or exc}")
    finally:
        fh.close()
    return None


def record_failure(out: Path, reason: str, head: dict) -> str | None:
    """A `failed` summary.json in OUT for bad input found before PETSc starts (rank 0 of
    the launcher; app/startup/early_failure.py); None, or why nothing was written."""
    return _record(out, reason, "failed", head)
