"""What every phase of a run shares: the config, the options, MPI, the timer, the summary."""

from __future__ import annotations

import sys
import time
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from pathlib import Path

from petsc4py import PETSc

from app.config import Config
from app.output.summary import write_summary as write_summary_file
from app.parallel import Timer


@dataclass
class RunOptions:
    """Command-line choices that override the config."""

    out: Path = Path("out")
    method: str | None = None
    sd: int | None = None
    mesh_scale: float = 1.0
    quiet: bool = False
    mesh_cache: Path | None = None
    progress_prefix: str = ""  # e.g. "level 2 of 0..4 CS-FEM-4SD" in a study
    overrides: list[str] = field(default_factory=list)  # the --set strings (provenance)
    refine: int = 0  # uniform splits of the (scaled) config mesh, see app/mesh/refine.py
    started: float | None = None  # perf_counter at PETSc start-up (cli): the `startup` phase
    launched: float | None = None  # perf_counter at the process's start: the `launch` phase
    allow_large: bool = False  # --allow-large: also run when the dense contact matrices
    #                            would not fit (app/condensation/dense_size.py)


@dataclass
class RunContext:
    """One run: config and options, the communicator (rank, size), the phase timer, the
    summary being built (written to OUT/summary.json on rank 0) and the output folder."""

    cfg: Config
    opts: RunOptions
    summary: dict
    comm: PETSc.Comm = field(default_factory=lambda: PETSc.COMM_WORLD)
    timer: Timer | None = None  # run_timer(opts) made before the run's guard, or a new one
    warned: set = field(default_factory=set)  # keys of the once-per-run warnings given

    def __post_init__(self) -> None:
        if self.timer is None:
            self.timer = run_timer(self.opts)
        if self.opts.started is not None:  # imports, config checks, provenance, --out lock
            self.timer.count_from(self.opts.started, "startup")
        else:  # a study's run: its clock starts here, with its first phase (as before)
            self.timer.start = time.perf_counter()

    @property
    def mpi(self):
        """The mpi4py communicator."""
        return self.comm.tompi4py()

    @property
    def rank(self) -> int:
        return self.comm.getRank()

    @property
    def size(self) -> int:
        return self.comm.getSize()

    @property
    def out(self) -> Path:
        return Path(self.opts.out)

    def phase(self, name: str) -> AbstractContextManager[None]:
        """A named phase (seconds in summary.json timings, a PETSc log stage)."""
        return self.timer.phase(name)

    def warn(self, text: str, key: tuple | None = None) -> None:
        """A warning: appended to the summary's `warnings`, one stderr line on rank 0;
        with a key, only the first time that key is given in the run."""
        if key is not None:
            if key in self.warned:
                return
            self.warned.add(key)
        self.summary.setdefault("warnings", []).append(text)
        if self.rank == 0:
            print(f"warning: {text}", file=sys.stderr, flush=True)


def run_timer(opts: RunOptions) -> Timer:
    """The run's phase timer: `launch` booked (the interpreter, imports, PETSc's and MPI's
    start) and `startup` open from PETSc's start-up (imports, config checks, provenance,
    the --out lock and clean-up), so that a stop before the first phase counts them too;
    RunContext closes `startup`."""
    prefix = f"{opts.progress_prefix}: " if opts.progress_prefix else ""
    timer = Timer(quiet=opts.quiet, prefix=prefix)
    if opts.started is not None:
        if opts.launched is not None and opts.launched < opts.started:
            timer.book("launch", opts.launched, opts.started)
        timer.begin("startup", opts.started)
    return timer


def write_summary(out: Path, summary: dict) -> None:
    """OUT/summary.json; later calls for the same run append (app/output/summary.py)."""
    write_summary_file(out / "summary.json", summary)
