"""A study's or sweep's answer to SIGINT / SIGTERM: whatever the signal interrupts (a run,
or the time between two runs) and on any number of ranks, rank 0 writes what the completed
runs give (the CSV, the tables, the plots) before the job ends.

On one rank the signal raises in the main thread (KeyboardInterrupt or RunInterrupted) and
`BatchGuard.__exit__` writes. On several ranks no rank stops by itself (see
app/output/status.py): inside a run, rank 0's run watchdog calls the hook registered here
before it exits; between runs, this guard's own watchdog does.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable

from petsc4py import PETSc

from app.output import startup_signals, status
from app.output.status import EXIT_SIGNAL, RunInterrupted, StopWatchdog


class BatchGuard:
    """Context manager around a batch of runs. `write_completed()` (rank 0) writes the
    completed runs' results and returns a one-line account of them; it is called at most
    once, and only on an interrupt."""

    def __init__(self, write_completed: Callable[[], str]):
        self.write_completed = write_completed
        self.rank = PETSc.COMM_WORLD.getRank()
        self._lock = threading.Lock()
        self._written = False
        self._old: tuple = ()
        self._watchdog: StopWatchdog | None = None

    def __enter__(self) -> BatchGuard:
        self._old = (signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM))
        status.arm_signals()
        status.on_stop(self.finish)
        self._watchdog = status.start_watchdog(self)
        early = startup_signals.finish()  # a signal of the study's start-up: stop now
        if early is not None:
            if PETSc.COMM_WORLD.getSize() > 1:
                self.stop_now(early)
            stop = KeyboardInterrupt() if early == "SIGINT" else RunInterrupted(early)
            self.__exit__(type(stop), stop, None)
            raise stop
        return self

    def finish(self) -> None:
        """Rank 0: write the completed runs (once) and print its account on stderr."""
        with self._lock:
            if self._written or self.rank != 0:
                return
            self._written = True
            try:
                line = self.write_completed()
            except Exception as exc:  # the interrupt's own line still follows
                line = f"the completed runs could not be summarised ({exc})"
            print(line, file=sys.stderr, flush=True)

    def stop_now(self, name: str) -> None:
        """From the watchdog thread (between runs, several ranks): write, report, exit.
        Every stop hook runs: this guard's `finish` and the study's summary.json
        (app/studies/batch_status.py)."""
        status.begin_stop(name)  # one thread ends the job (a run's guard yields to it)
        code = EXIT_SIGNAL.get(name, 130)
        try:  # (this thread holds the stop lock: it exits whatever fails here)
            peer = status.peer_failure()  # mpiexec's answer to a rank that failed alone
            reason = peer["error"] if peer else (
                f"interrupted by {name} between the runs; what completed before it is "
                "written")
            status._run_stop_hooks(reason, "failed" if peer else "interrupted")
            if self.rank == 0 and not (peer and peer.get("printed")):
                status._say(f"error: {reason}")
            code = peer["code"] if peer else code
        finally:
            startup_signals.exit_after_rank0(code)

    def __exit__(self, exc_type, exc, tb) -> bool:
        if self._watchdog is not None:
            self._watchdog.handled.set()  # the main thread stops here, in Python code
        if exc is None and PETSc.COMM_WORLD.getSize() > 1 and status.unacted_signal():
            # it came while the last run's rows were recorded: the watchdog waited for
            # them, then saw the guard ending and left it; the plots would be killed
            self.stop_now(status.unacted_signal())
        status.end_watchdog(self._watchdog)
        status.remove_on_stop(self.finish)
        for sig, old in zip((signal.SIGINT, signal.SIGTERM), self._old, strict=True):
            try:
                signal.signal(sig, old if old is not None else signal.SIG_DFL)
            except (ValueError, TypeError):
                pass
        if isinstance(exc, KeyboardInterrupt | RunInterrupted):
            self.finish()
        return False
