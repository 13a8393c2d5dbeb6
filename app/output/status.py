"""A truthful run status: the output-folder lock, stale files of an earlier run, SIGINT /
SIGTERM, a full disk, non-finite results, and the final summary.json on every exit.

`RunGuard` wraps a run: on entry rank 0 locks OUT (fcntl lock on OUT/.lock; a second
run into the same folder is refused) and removes the files an earlier run of this tool
left there (step_NNNN.h5, the XDMF indexes, mesh.h5, their .tmp files); on exit it
writes summary.json with status `completed`, `failed` or `interrupted` and the reason,
removes half-written temporary files and releases the lock.
"""

from __future__ import annotations

import fcntl
import os
import re
import signal
import sys
import threading
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TextIO

import numpy as np
from petsc4py import PETSc

from app import exit_sync, hard_stop
from app.errors import InputError, SolveError
from app.output import startup_signals
from app.output.out_owner import UnsafeLock, foreign_files, foreign_message, open_lock
from app.output.plot_mark import is_marked_png

LOCK_NAME = startup_signals.LOCK_NAME
STALE = startup_signals.STALE
"""Files this tool writes into OUT (and their temporary names)."""
TEMPORARY = re.compile(r"^(step_\d{4,}\.h5|results\.xdmf|contact\.xdmf|mesh\.h5|"
                       r"summary\.json)\.tmp$")
EXIT_SIGNAL = startup_signals.EXIT_SIGNAL


class RunInterrupted(BaseException):
    """The run was stopped by a signal (SIGINT or SIGTERM); args[0] is the signal name.
    A BaseException, as KeyboardInterrupt: `except Exception` blocks let it through."""

    summary: dict | None = None  # the run's summary when the guard saw the signal

    @property
    def signal_name(self) -> str:
        return self.args[0] if self.args else "SIGINT"

    @property
    def exit_code(self) -> int:
        return EXIT_SIGNAL.get(self.signal_name, 130)

    def __str__(self) -> str:
        return self.args[1] if len(self.args) > 1 else f"interrupted by {self.signal_name}"


def _raise_sigterm(signum, frame):
    raise RunInterrupted("SIGTERM")


def _stops_on_signal() -> bool:
    """Whether the main thread stops the run on a signal (raises): only in a run on one
    rank. On several ranks a rank that stopped by itself would leave the others blocked in
    a collective (and rank 0 could not finish writing), so there every rank only notes
    the signal and rank 0's watchdog stops the job at once between steps (StopWatchdog)."""
    return PETSc.COMM_WORLD.getSize() == 1


def arm_signals():
    """SIGTERM raises RunInterrupted, SIGINT KeyboardInterrupt (a run on several ranks
    only notes them, see `_stops_on_signal`); returns the previous SIGTERM handler. Call
    again after gmsh ran: gmsh.finalize() resets both to the defaults."""
    try:
        if not _stops_on_signal():
            old = signal.signal(signal.SIGTERM, _record_signal)
            signal.signal(signal.SIGINT, _record_signal)
            return old
        old = signal.signal(signal.SIGTERM, _raise_sigterm)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    except ValueError:  # not the main thread
        return None
    return old


_PENDING: list[str] = []
_ON_FAILURE: list = []


def on_failure(fn) -> None:
    """Call fn() (rank 0) when the run fails or is interrupted, before summary.json is
    written (e.g. to put the XDMF indexes back to the completed steps)."""
    _ON_FAILURE.append(fn)


_ON_STOP: list[Callable[[], None]] = []


def on_stop(fn: Callable[[], None]) -> None:
    """Call fn() (every rank; it acts on rank 0) when a watchdog ends the job on a signal,
    after the run's summary.json is written: a study or sweep writing what completed
    (app/output/batch_guard.py)."""
    _ON_STOP.append(fn)


def remove_on_stop(fn: Callable[[], None]) -> None:
    """Undo `on_stop(fn)`."""
    if fn in _ON_STOP:
        _ON_STOP.remove(fn)


_STOP_REASON: list[str] = []
"""The `error` line of the signal a watchdog ends the job on (for the stop hooks)."""
_STOP_STATUS: list[str] = []


def stop_reason() -> str | None:
    """In a stop hook: the reason the job ends (the `error:` line), else None."""
    return _STOP_REASON[-1] if _STOP_REASON else None


def stop_status() -> str:
    """In a stop hook: `interrupted`, or `failed` when the signal is mpiexec's answer to
    another rank's failure (`peer_failure`)."""
    return _STOP_STATUS[-1] if _STOP_STATUS else "interrupted"


def peer_failure() -> dict | None:
    """Rank 0 ending the job on a signal: the note of a rank that failed alone (its exit
    made mpiexec send the signal; app/exit_sync.py), or None (on other ranks too)."""
    return exit_sync.peer_failure() if PETSc.COMM_WORLD.getRank() == 0 else None


def _run_stop_hooks(reason: str | None = None, state: str = "interrupted") -> None:
    if reason is not None:
        _STOP_REASON.append(reason)
        _STOP_STATUS.append(state)
    for fn in list(_ON_STOP):
        try:
            fn()
        except Exception as exc:  # the job ends anyway; say why the hook wrote nothing
            _say(f"warning: {exc}")


_STOP_LOCK = threading.Lock()
"""Taken, and never released (the process exits), by whoever ends the job on a signal:
the watchdog's `RunGuard.stop_now`, a study's `BatchGuard.stop_now` (`begin_stop`), or
`_hand_off_pending` to the C handler. Both at once wrote summary.json over each other (a
stray summary.json.tmp). `RunGuard.__exit__` holds it while it writes the run's end."""


STOP_WAIT_SECONDS = 30.0
"""How long the main thread waits for the job's end once the thread that ends it
(`begin_stop`) is no longer running (or is not known) before it exits by itself."""

_STOP_CODE: list[int] = []
_STOPPER: list[threading.Thread] = []


def begin_stop(name: str) -> None:
    """Take `_STOP_LOCK` for good: the caller (a watchdog's `stop_now`) ends the job on the
    signal `name` and exits with its code; `RunGuard.__exit__` on the main thread then
    leaves the run's files and summary to it (`wait_for_the_stop`)."""
    _STOP_LOCK.acquire()
    _STOP_CODE.append(EXIT_SIGNAL.get(name, 130))
    _STOPPER.append(threading.current_thread())


def wait_for_the_stop() -> None:
    """The main thread while another thread ends the job: write nothing, wait for its exit.
    Its clear_files removed the temporary file the main thread was writing (mesh.h5.tmp,
    summary.json.tmp): the main thread's rename failed with `No such file or directory`,
    and its `failed` summary (and error line) replaced the watchdog's `interrupted` before
    the watchdog exited (2 of about 400 sweep trials on 2 ranks).
    It waits as long as that thread runs (a study's stop hooks write its tables and, on one
    rank, its plots: a fixed wait could end the job in the middle of them), then at most
    STOP_WAIT_SECONDS. A further signal does not end the wait (on one rank Ctrl-C again
    raised KeyboardInterrupt out of the sleep: the main thread went on to exit by itself
    while the other thread was writing)."""
    import time

    stopper = _STOPPER[-1] if _STOPPER else None
    end = time.monotonic() + STOP_WAIT_SECONDS
    while True:
        try:
            if (stopper is not None and stopper is not threading.current_thread()
                    and stopper.is_alive()):
                stopper.join()  # (it exits the process: this returns only if it failed to)
                end = time.monotonic()
            if (left := end - time.monotonic()) <= 0:
                break
            time.sleep(left)
        except (KeyboardInterrupt, RunInterrupted):
            continue
    os._exit(_STOP_CODE[0] if _STOP_CODE else 130)


def _say(line: str) -> None:
    """The stopping thread's line on stderr; a closed stderr (a pipe whose reader ended)
    does not keep it from exiting."""
    try:
        print(line, file=sys.stderr, flush=True)
    except (OSError, ValueError):
        pass


def _hand_off_pending() -> str | None:
    """The name of a signal recorded but not acted on, for app/hard_stop.py to raise into
    the C handler it has just armed (the watchdog thread would wait for the GIL through the
    long call); None if there is none. While another thread is ending the job it puts the
    handlers back and waits for the job's end: before, it waited with the C handler armed,
    and a second signal (Ctrl-C in a terminal: SIGINT, then mpiexec's SIGTERM) wrote the
    summary from C over the other thread's (an in-place tail at an offset of the layout
    the C handler was armed with, not the one that thread wrote)."""
    if not _STOP_LOCK.acquire(blocking=False):
        hard_stop.disarm()
        wait_for_the_stop()
    if _PENDING:
        return _PENDING[0]  # (the lock kept: the C handler ends the job)
    _STOP_LOCK.release()
    return None


def unacted_signal() -> str | None:
    """The first signal recorded while a guard only noted signals (several ranks, or a
    step being written) that nobody acted on; None if none."""
    return _PENDING[0] if _PENDING else None


def _record_signal(signum, frame):
    _PENDING.append(signal.Signals(signum).name)


def hold_signals() -> None:
    """Defer SIGINT and SIGTERM (while a step's files and summary.json are written, so
    that the files on disk and the summary agree); `release_signals` acts on them."""
    _PENDING.clear()
    try:
        signal.signal(signal.SIGINT, _record_signal)
        signal.signal(signal.SIGTERM, _record_signal)
    except ValueError:  # not the main thread
        pass


def release_signals() -> None:
    """Put the run's handlers back; raise for a signal that came while they were held."""
    try:
        if _stops_on_signal():
            signal.signal(signal.SIGINT, signal.default_int_handler)
    except ValueError:
        return
    arm_signals()
    if _PENDING and _stops_on_signal():
        if _WATCHDOG:
            _WATCHDOG[-1].handled.set()  # stopping here, in Python code
        name = _PENDING[0]
        _PENDING.clear()
        if name == "SIGINT":
            raise KeyboardInterrupt
        raise RunInterrupted(name)


def lock_folder(out: Path) -> TextIO:
    """Create OUT, take its lock (non-blocking); returns the open lock file."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        fh = open_lock(out / LOCK_NAME)
    except UnsafeLock as exc:  # a link or a FIFO planted there: not followed
        raise InputError(str(exc)) from None
    except OSError as exc:
        raise InputError(f"--out {out}: cannot write there ({exc.strerror})") from None
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        fh.close()
        raise InputError(f"--out {out}: another run is writing into this folder (it holds "
                         f"{out / LOCK_NAME}); wait for it or choose another --out") from None
    return fh


def clear_files(out: Path, pattern: re.Pattern = STALE,
                also: Callable[[Path], bool] | None = None) -> list[str]:
    """Remove the files of OUT whose names match, or for which `also` holds (this tool's
    output only: e.g. `is_marked_png`, scripts/plot_results.py's pictures)."""
    removed = []
    for p in sorted(out.iterdir()):
        # a link under the tool's names too (dangling ones: `is_file` is False), not only
        # files: else the run wrote through it, outside OUT (a `.tmp` one planted there)
        if (p.is_symlink() and pattern.match(p.name)) or \
                (p.is_file() and (pattern.match(p.name) or (also is not None and also(p)))):
            try:
                p.unlink()
                removed.append(p.name)
            except OSError:
                pass
    return removed


def check_finite(step: int, n_steps: int, u: np.ndarray, energy: float) -> None:
    """Non-finite displacements or strain energy fail the step (SolveError)."""
    bad = [name for name, ok in (("displacements", bool(np.all(np.isfinite(u)))),
                                 ("strain energy", bool(np.isfinite(energy)))) if not ok]
    if bad:
        raise SolveError(f"step {step}/{n_steps}: non-finite {' and '.join(bad)} (inf or "
                         "NaN): the loads or material values exceed the range of float64")


def write_summary_robust(write, out: Path, summary: dict) -> bool:
    """Write summary.json with `write` (atomic); on a full disk, remove temporary files
    and overwrite summary.json in place. Returns False if nothing could be written."""
    import json

    try:
        write(out, summary)
        return True
    except OSError:
        clear_files(out, TEMPORARY)
    try:
        with open(out / "summary.json", "w") as fh:
            fh.write(json.dumps(summary, indent=2) + "\n")
        return True
    except OSError:
        return False


def _os_reason(exc: OSError) -> str:
    """One line for an OSError, also for h5py's (errno only inside the message)."""
    if exc.errno:
        return exc.strerror or os.strerror(exc.errno)
    text = str(exc)
    m = re.search(r"errno = (\d+)", text)
    if m:
        return os.strerror(int(m.group(1)))
    return text.splitlines()[0] if text else type(exc).__name__


PETSC_ERRORS = {55: "out of memory", 56: "no support for this operation", 62: "invalid "
                "argument", 63: "argument out of range", 73: "object in the wrong state",
                76: "error in an external library", 86: "unknown type"}


def _petsc_reason(exc: Exception) -> str:
    """One line for a PETSc.Error: its code, what the code means, the options in force."""
    from app.petsc_options import petsc_error_line

    code = getattr(exc, "ierr", None)
    opts = " ".join(f"-{k} {v}".rstrip() for k, v in sorted(PETSc.Options().getAll().items()))
    line = petsc_error_line(exc)
    meaning = PETSC_ERRORS.get(code, "see the PETSc manual")
    if "must have at least two fields" in line:  # -pc_type fieldsplit, no fields given
        meaning = ("the stiffness matrix names no fields: -pc_fieldsplit_block_size 2 "
                   "splits it into the x and y displacements, interleaved per node")
    detail = f"{line} ({meaning})" if line and not line.startswith("error code") else \
        f"error {code} ({meaning})"
    return f"PETSc: {detail}; check the PETSc options in force: {opts}"


STOP_GRACE_SECONDS = 3.0
"""After SIGINT/SIGTERM, how long the run may take to reach Python code and stop there
before the watchdog writes summary.json and exits (a long gmsh or Lemke call; a PETSc
call such as the MUMPS factorization keeps the GIL, so the watchdog waits for its end:
app/hard_stop.py acts there on several ranks)."""


def stop_grace(rank: int, ranks: int) -> float:
    """Seconds the watchdog of `rank` (of `ranks`) waits for the run to stop by itself.
    On several ranks no main thread stops by itself: rank 0's watchdog stops the job at
    once (after the step being written; Open MPI's mpiexec sends SIGKILL as soon as a
    rank has ended, at the latest 1 s after the SIGTERM it forwards, also on Ctrl-C), the
    others only if rank 0 did not end the job."""
    return 0.0 if ranks > 1 and rank == 0 else STOP_GRACE_SECONDS


class StopWatchdog:
    """A thread that sees SIGINT/SIGTERM at once (signal.set_wakeup_fd) even while the
    main thread is inside a long C call, where Python's handlers cannot run: if the run
    has not stopped by itself within STOP_GRACE_SECONDS (and no step is being written),
    it records the status `interrupted`, prints the reason and exits with 130 / 143."""

    def __init__(self, guard: RunGuard, grace: float = STOP_GRACE_SECONDS):
        # guard: whatever ends the job on the signal, through guard.stop_now(name): the
        # run's RunGuard, or a study's BatchGuard between its runs
        import threading

        self.guard = guard
        self.grace = grace
        self.handled = threading.Event()
        self.writing = threading.Lock()  # held by the main thread while a step is written
        self._r, self._w = os.pipe()
        os.set_blocking(self._w, False)
        self._old_fd = signal.set_wakeup_fd(self._w)
        self._thread = threading.Thread(target=self._watch, daemon=True)
        self._thread.start()

    def _watch(self) -> None:
        while True:
            try:
                data = os.read(self._r, 1)
            except OSError:
                return
            if not data:
                return
            signum = data[0]
            if signum not in (signal.SIGINT, signal.SIGTERM):
                continue
            if self.handled.wait(self.grace):
                return
            with self.writing:  # never in the middle of a step's files
                if self.handled.is_set():
                    return
                self.guard.stop_now(signal.Signals(signum).name)

    def close(self) -> None:
        """Stop watching: restore the previous signal wake-up fd and end the thread."""
        self.handled.set()
        try:
            signal.set_wakeup_fd(self._old_fd)
        except ValueError:
            pass
        os.close(self._w)  # the thread reads EOF and ends
        self._thread.join(timeout=5)
        os.close(self._r)


_WATCHDOG: list[StopWatchdog] = []


def start_watchdog(guard) -> StopWatchdog | None:
    """A StopWatchdog for `guard` (a RunGuard or a study's BatchGuard), on top of the
    stack `step_writing` uses; None off the main thread (no watchdog there)."""
    comm = PETSc.COMM_WORLD
    try:
        watchdog = StopWatchdog(guard, stop_grace(comm.getRank(), comm.getSize()))
    except ValueError:
        return None
    _WATCHDOG.append(watchdog)
    return watchdog


def end_watchdog(watchdog: StopWatchdog | None) -> None:
    """Undo `start_watchdog` (set `watchdog.handled` first where the guard stops itself):
    off the stack, the writing lock released, the thread and the wakeup fd closed."""
    if watchdog is None:
        return
    if watchdog in _WATCHDOG:
        _WATCHDOG.remove(watchdog)
    if watchdog.writing.locked():
        watchdog.writing.release()
    watchdog.close()


def step_writing(active: bool) -> None:
    """Tell the watchdog that a step's files are being written (True) or done (False)."""
    if _WATCHDOG:
        lock = _WATCHDOG[-1].writing
        if active:
            lock.acquire()
        elif lock.locked():
            lock.release()


@contextmanager
def writing() -> Iterator[None]:
    """`step_writing` around a write of the run's files outside a step's (mesh.h5, the
    final or failed summary.json): a watchdog's stop waits for it, and one under way
    holds the main thread here until it has ended the job (before, its clear_files removed
    the file's .tmp under the main thread, and the main thread's `completed` or `failed`
    replaced its `interrupted`)."""
    step_writing(True)
    try:
        yield
    finally:
        step_writing(False)


class RunGuard:
    """Context manager around a run: lock, stale files, signals, final status."""

    def __init__(self, out: Path, summary: dict, write, n_steps: int, timer=None):
        # timer: the run's app.parallel.Timer (its `local` seconds go into the summary of
        # a failed or interrupted run), or None (no timings then)
        self.out = Path(out)
        self.timer = timer
        self.summary = summary
        self.write = write
        self.n_steps = n_steps
        self.rank = PETSc.COMM_WORLD.getRank()
        self._lock = None
        self._old_term = None
        self._old_int = None
        self._watchdog: StopWatchdog | None = None
        self.removed: list[str] = []

    def __enter__(self) -> RunGuard:
        from app.parallel import collective

        def start():
            self._lock = lock_folder(self.out)
            foreign = foreign_files(self.out, STALE)
            if foreign:
                raise InputError(foreign_message(self.out, foreign))
            token = uuid.uuid4().hex  # this run's notes (exit_sync.note_in)
            exit_sync.note_in(self.out, 0, token)  # (before the others go on)
            return clear_files(self.out, also=is_marked_png), token

        _ON_FAILURE.clear()
        startup_signals.defer()  # a signal now is acted on below, not between these writes
        self.removed, token = collective(start)
        if self.rank != 0:
            exit_sync.note_in(self.out, self.rank, token)
        self._write_running()
        self._old_int = signal.getsignal(signal.SIGINT)
        self._old_term = arm_signals()
        early = startup_signals.finish()
        self._old_int = startup_signals.unwrap(signal.SIGINT, self._old_int)
        self._old_term = startup_signals.unwrap(signal.SIGTERM, self._old_term)
        self._watchdog = start_watchdog(self)
        if self._watchdog is not None and self._watchdog.grace == 0.0:
            # where the watchdog stops at once, also inside long C calls
            hard_stop.set_provider(self._hard_stop_text, _hand_off_pending)
        if early is not None:  # a signal of the start-up phase: stop as at any other time
            if not _stops_on_signal():
                self.stop_now(early)
            stop = KeyboardInterrupt() if early == "SIGINT" else RunInterrupted(early)
            self.__exit__(type(stop), stop, None)  # writes `interrupted`, raises
        return self

    def _write_running(self) -> None:
        """The `running` summary (rank 0) and the stop hook that turns it `interrupted`,
        under the stop lock: a study's watchdog that ends the job before them leaves this
        run unstarted (no summary.json: `not run` in sweep.csv), one after them sees the
        hook. Before, its hooks could run between the two, and the run's summary stayed
        `running` (1 of 18 `check_interrupts.py --sweep` trials on 2 ranks)."""
        if not _STOP_LOCK.acquire(blocking=False):
            wait_for_the_stop()  # a watchdog is ending the job (it exits the process)
            return
        try:
            if self.rank == 0:
                self.write(self.out, self.summary)
            _ON_STOP.insert(0, self._stopped_before_its_watchdog)
        finally:
            _STOP_LOCK.release()

    def stop_now(self, name: str) -> None:
        """From the watchdog thread: record `interrupted` (or, when the signal answers
        another rank's failure, `failed` with its reason), print it and exit at once."""
        begin_stop(name)  # (a hand-off to the C handler took it first: it exits)
        code = EXIT_SIGNAL.get(name, 130)
        try:  # whatever fails below, this thread holds the stop lock: it must exit
            code = self._record_stop(name) or code
        finally:
            startup_signals.exit_after_rank0(code)

    def _record_stop(self, name: str) -> int | None:
        """stop_now's writes: summary.json `interrupted`, the error line, the stop hooks;
        `failed` with a peer's line and its exit status (returned) when a rank failed
        alone (before: `interrupted by SIGTERM`, mpiexec's answer to its exit).
        An OSError here (OUT gone, stderr a closed pipe) used to end the watchdog thread
        with the stop lock held: the run went on, its steps' summaries replaced
        `interrupted`, and its end waited STOP_WAIT_SECONDS and exited with no line."""
        import json

        where = ("" if PETSc.COMM_WORLD.getSize() > 1 else
                 " (stopped inside a long computation)")
        peer = peer_failure()
        state = "failed" if peer else "interrupted"
        reason = peer["error"] if peer else self._interrupted_reason(name, where)
        self.summary["status"] = state
        self.summary["error"] = reason
        timings = self._timings()  # (in the text only: the main thread may be writing the dict)
        if peer and "steps" in self.summary and len(self.summary["steps"]) < self.n_steps:
            self.summary.setdefault("failed_step", len(self.summary["steps"]) + 1)
        if self.rank == 0:
            try:
                clear_files(self.out, TEMPORARY)
            except OSError:  # (OUT unreadable or gone: the summary below fails alike)
                pass
            for _ in range(5):  # the main thread may be changing the dict
                try:  # (its status and error too: a `completed` with this error was seen)
                    text = json.dumps({**self.summary, **timings, "status": state,
                                       "error": reason}, indent=2) + "\n"
                    break
                except RuntimeError:
                    continue
            else:
                text = None
            if text is not None:
                try:
                    from app.output.xdmf import atomic_write_bytes

                    atomic_write_bytes(self.out / "summary.json", text.encode())
                except OSError:
                    pass
            if not (peer and peer.get("printed")):
                _say(f"error: {reason}")
        _run_stop_hooks(reason, state)
        return peer["code"] if peer else None

    def __exit__(self, exc_type, exc, tb) -> bool:
        hard_stop.set_provider(None)
        watchdog = self._watchdog
        if watchdog is not None:
            watchdog.handled.set()  # the run reached Python code and stops here
        try:
            if not _STOP_LOCK.acquire(blocking=False):
                wait_for_the_stop()  # a watchdog is ending the job: its files, its line
            try:  # (a watchdog's stop_now waits for these writes, then overwrites them)
                return self._finish(exc)
            finally:
                _STOP_LOCK.release()
        finally:
            end_watchdog(watchdog)
            remove_on_stop(self._stopped_before_its_watchdog)
            _ON_FAILURE.clear()
            if self._old_term is not None:
                signal.signal(signal.SIGTERM, self._old_term)
                signal.signal(signal.SIGINT, self._old_int or signal.default_int_handler)
            if self._lock is not None:
                self._lock.close()

    def _stopped_before_its_watchdog(self) -> None:
        """Stop hook (rank 0): a study's watchdog ended the job after this guard wrote its
        `running` summary and before its own watchdog took over (seen 1 in 50 trials on 2
        ranks): the summary says `interrupted`, not `running`. A no-op once the run's own
        stop or end has set another status."""
        if self.rank != 0 or self.summary.get("status") != "running":
            return
        named = re.match(r"interrupted by (SIG[A-Z]+)", stop_reason() or "")
        self.summary["status"] = "interrupted"
        self.summary["error"] = self._interrupted_reason(named[1] if named else "a signal")
        self._stop_timings()
        self.write(self.out, self.summary)

    def _interrupted_reason(self, name: str, where: str = "") -> str:
        """The `error` line; after the last step (the final output, the reference) it says
        so (before: `during step N+1/N`)."""
        k = len(self.summary.get("steps", []))
        at = (f"after the last step ({k}/{self.n_steps})" if k >= self.n_steps > 0
              else f"during step {k + 1}/{self.n_steps}")
        return f"interrupted by {name} {at}{where}; {self._done()}"

    def _hard_stop_text(self, name: str) -> tuple[Path, int, bytes, str]:
        """What app/_hard_stop.c writes on `name` during a long C call (rank 0): the
        summary's path, the offset of an in-place write of its new tail (-1: the whole
        file), the bytes, the stderr line. The in-place tail keeps the cost per call flat
        in the number of steps (the whole text is O(steps): 170 ms at 400 steps)."""
        import json

        from app.output.summary import tail_patch

        reason = self._interrupted_reason(name)
        summary = {**self.summary, **self._timings(), "status": "interrupted",
                   "error": reason}
        path = self.out / "summary.json"
        patch = tail_patch(path, summary, ("error", "stopped_in_phase"))
        if patch is not None:
            return path, patch[0], patch[1], f"error: {reason}\n"
        return path, -1, (json.dumps(summary, indent=2) + "\n").encode(), f"error: {reason}\n"

    def _timings(self) -> dict:
        """`timings` (this rank's seconds per phase so far and `total`, no collective: rank 0
        writes the summary, and a rank that failed alone or a watchdog thread cannot wait
        for the others) and `stopped_in_phase` (the phase the run stopped in, if known), for
        a failed or interrupted run's summary; {} without a timer (a failure before the run)."""
        if self.timer is None:
            return {}
        timings, phase = self.timer.local()
        return {"timings": timings} | ({"stopped_in_phase": phase} if phase else {})

    def _stop_timings(self) -> None:
        """Put `_timings()` into the summary (a failed or interrupted end)."""
        self.summary.update(self._timings())

    def _done(self) -> str:
        k = len(self.summary.get("steps", []))
        return f"steps 1..{k} are written in {self.out}" if k else "no step completed"

    def _finish(self, exc: BaseException | None) -> bool:
        s = self.summary
        if exc is None:
            return False
        if isinstance(exc, KeyboardInterrupt | RunInterrupted):
            name = exc.signal_name if isinstance(exc, RunInterrupted) else "SIGINT"
            s["status"] = "interrupted"
            s["error"] = self._interrupted_reason(name)
            self._stop_timings()
            self._record()
            stop = RunInterrupted(name, s["error"])
            stop.summary = s
            raise stop from None
        s["status"] = "failed"
        self._stop_timings()
        if "steps" in s and "failed_step" not in s and len(s["steps"]) < self.n_steps:
            s["failed_step"] = len(s["steps"]) + 1
        if isinstance(exc, OSError):
            s["error"] = (f"cannot write the results into {self.out}: {_os_reason(exc)}; "
                          f"{self._done()}")
            self._record()
            raise InputError(s["error"]) from None
        if isinstance(exc, MemoryError):  # was a numpy traceback, exit 1
            s["error"] = (f"out of memory ({exc or 'MemoryError'}): use a larger --mesh-size or "
                          f"mesh.size, or fewer contact pairs; {self._done()}")
            self._record()
            raise InputError(s["error"]) from None
        if isinstance(exc, PETSc.Error):
            s["error"] = f"{_petsc_reason(exc)}; {self._done()}"
            self._record()
            raise InputError(s["error"]) from None
        if isinstance(exc, InputError | SolveError):
            s["error"] = str(exc)
        else:
            s["error"] = f"{type(exc).__name__}: {exc}"
        self._record()
        return False

    def _record(self) -> None:
        if self.rank != 0:
            return
        clear_files(self.out, TEMPORARY)
        for fn in _ON_FAILURE:
            try:
                fn()
            except OSError:
                pass
        _ON_FAILURE.clear()
        if not write_summary_robust(self.write, self.out, self.summary):
            print(f"warning: could not update {self.out / 'summary.json'}", file=sys.stderr)
