"""MPI helpers of the driver: the phase timer, rank-0 calls with broadcast errors, and
vectors between PETSc and numpy. Every rank runs them (collective operations)."""

from __future__ import annotations

import resource
import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from petsc4py import PETSc

from app.errors import InputError, SolveError


@dataclass
class Timer:
    """Wall-clock seconds per phase (max over ranks is reported) and PETSc log stages."""

    seconds: dict[str, float] = field(default_factory=dict)
    peak_mb: dict[str, float] = field(default_factory=dict)
    quiet: bool = False
    prefix: str = ""
    start: float = field(default_factory=time.perf_counter)
    _stages: dict = field(default_factory=dict)
    _open: list = field(default_factory=list)  # (name, perf_counter at entry), outermost first
    failed_in: str | None = None  # the innermost phase an exception (or a signal) left

    @contextmanager
    def phase(self, name: str) -> Iterator[None]:
        """Time the block as phase `name` (wall seconds, added up; barriers on entry and
        exit, so the slowest rank counts) in its own PETSc log stage; records the peak
        memory at its end and prints a progress line unless quiet."""
        t0 = time.perf_counter()  # the barriers count too: all of a run is in some phase
        comm = PETSc.COMM_WORLD
        if name not in self._stages:
            self._stages[name] = PETSc.Log.Stage(name)
        stage = self._stages[name]
        stage.push()
        self._open.append((name, t0))
        failed = True
        try:
            comm.barrier()  # a phase's time includes waiting for the slowest rank
            yield
            failed = False
        finally:
            self._open.remove((name, t0))
            if failed and self.failed_in is None:
                self.failed_in = name
            self.peak_mb[name] = peak_rss_mb()
            if not failed:  # a rank that failed alone must not wait for the others here
                comm.barrier()
            stage.pop()
            dt = time.perf_counter() - t0
            self.seconds[name] = self.seconds.get(name, 0.0) + dt
            if not self.quiet and comm.getRank() == 0:
                el = time.perf_counter() - self.start
                print(f"[{el:8.2f} s] {self.prefix}{name:<14s} {dt:8.3f} s", file=sys.stderr,
                      flush=True)

    def count_from(self, t0: float, name: str) -> None:
        """Start the run's clock at t0 (perf_counter seconds) and book the time since
        then as the phase `name` (what ran before the timer existed). No progress line:
        an input error found before the first phase stays a one-line message."""
        self._open = [o for o in self._open if o[0] != name]
        self.book(name, t0, time.perf_counter())

    def begin(self, name: str, t0: float) -> None:
        """Open the phase `name` at t0 (perf_counter seconds) before the code that runs in
        it can use `phase` (the run's start-up, closed by `count_from`): a stop before its
        end counts its seconds so far (`local`). Starts the run's clock at t0."""
        self.start = min(self.start, t0)
        self._open.append((name, t0))

    def book(self, name: str, t0: float, t1: float) -> None:
        """Book the interval t0..t1 (perf_counter seconds, before the timer existed) as
        phase `name`, and start the run's clock at t0 if that is earlier. No progress line."""
        self.start = min(self.start, t0)
        self.seconds[name] = self.seconds.get(name, 0.0) + t1 - t0
        self.peak_mb[name] = peak_rss_mb()

    def reduced(self) -> dict[str, float]:
        """Seconds per phase, the maximum over the ranks (collective), sorted by name."""
        comm = PETSc.COMM_WORLD.tompi4py()
        out = {}
        for k in sorted(self.seconds):
            out[k] = comm.allreduce(self.seconds[k], op=_mpi_max())
        return out

    def local(self) -> tuple[dict[str, float], str | None]:
        """This rank's seconds per phase now, without any collective (a failed or
        interrupted run's summary: from the main thread after an exception, the watchdog
        thread or the C handler's text): the completed phases, the seconds so far of the
        phases still open, and `total`; and the phase the run stopped in (the innermost
        open one, else the one an exception left, else None: between phases)."""
        now = time.perf_counter()
        for _ in range(5):  # the watchdog thread: the main thread may change the dicts
            try:
                seconds, open_ = dict(self.seconds), list(self._open)
                break
            except RuntimeError:
                continue
        else:
            seconds, open_ = {}, []
        for name, t0 in open_:
            seconds[name] = seconds.get(name, 0.0) + now - t0
        out = {k: seconds[k] for k in sorted(seconds)}
        out["total"] = now - self.start
        return out, (open_[-1][0] if open_ else self.failed_in)

    def total(self) -> float:
        """Seconds since the timer started, max over ranks: the ranks start their timers at
        different moments, and a phase's seconds (max over ranks) include the early ranks'
        wait for the late ones, so a rank-local total could be less than the phases' sum."""
        comm = PETSc.COMM_WORLD.tompi4py()
        return comm.allreduce(time.perf_counter() - self.start, op=_mpi_max())

    def memory(self) -> dict[str, float]:
        """Peak resident memory (MB) of the whole job, summed over ranks, at the end of
        each phase's first completion order (a running maximum)."""
        comm = PETSc.COMM_WORLD.tompi4py()
        return {k: round(comm.allreduce(v), 1) for k, v in sorted(self.peak_mb.items())}


def peak_rss_mb() -> float:
    """Peak resident memory of this process (MB): VmHWM from /proc/self/status, which
    stays cheap under load (getrusage took milliseconds a call on a busy machine)."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _mpi_max():
    from mpi4py import MPI

    return MPI.MAX


class PeerFailure(Exception):
    """Raised on the other ranks when rank 0 failed alone in a rank-0 call with an error
    that is no user error (a bug, MemoryError, ...): they leave the collective with it and
    end quietly with `code`, the exit status rank 0 ends with (its traceback or line is
    its own). Before, they waited in the broadcast and the job hung in MPI_Finalize."""

    def __init__(self, code: int, text: str):
        super().__init__(text)
        self.code = code

    def __reduce__(self):  # broadcast by pickling: keep the code
        return (PeerFailure, (self.code, str(self)))


ONE_LINE_FAILURES = (InputError, SolveError, OSError, MemoryError, PETSc.Error)
"""What the run's guard (app/output/status.py `_finish`) turns into a one-line error, exit
2; anything else ends rank 0 with its traceback, exit 1."""


def peer_failure(exc: BaseException) -> PeerFailure:
    """What the other ranks raise when rank 0 raised `exc` alone."""
    return PeerFailure(2 if isinstance(exc, ONE_LINE_FAILURES) else 1,
                       f"rank 0 failed: {type(exc).__name__}: {exc}")


def rank0_call(fn: Callable[..., Any], *args: Any, share_result: bool = True,
             **kwargs: Any) -> Any:
    """fn(*args, **kwargs) on rank 0; an InputError or SolveError it raises is raised on
    every rank, any other exception on rank 0 and a PeerFailure on the others. Its result
    on every rank (share_result), else on rank 0 (None elsewhere: an object that stays on
    rank 0, e.g. the contact stepper)."""
    comm = PETSc.COMM_WORLD.tompi4py()
    result, error, own = None, None, None
    if comm.rank == 0:
        try:
            result = fn(*args, **kwargs)
        except (InputError, SolveError) as exc:
            error = exc
        except Exception as exc:  # noqa: BLE001 - shared so that no rank waits for it
            own, error = exc, peer_failure(exc)
    if share_result:
        result, error = comm.bcast((result, error), root=0)
    elif comm.size > 1:
        shared = comm.bcast(error, root=0)
        error = error if error is not None else shared
    if own is not None:
        raise own
    if error is not None:
        raise error
    return result


def collective(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Any:
    """Run fn on rank 0 and broadcast its result, or its InputError/SolveError, to all."""
    return rank0_call(fn, *args, **kwargs)


def to_numpy_all(vec: PETSc.Vec) -> np.ndarray:
    """A copy of a distributed vector on every rank."""
    scatter, seq = PETSc.Scatter.toAll(vec)
    scatter.scatter(vec, seq, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    out = seq.getArray().copy()
    scatter.destroy()
    seq.destroy()
    return out


def from_numpy(template: PETSc.Mat, values: np.ndarray) -> PETSc.Vec:
    """A distributed vector with this rank's slice of a global numpy array."""
    v = template.createVecLeft()
    r0, r1 = v.getOwnershipRange()
    v.setArray(values[r0:r1])
    return v
