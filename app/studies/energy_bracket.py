"""`run --energy-bracket`: the CS-FEM energy bracket of a scene as an a-posteriori estimate.

CS-FEM-1SD is the softest and FEM-Q4 the stiffest of the methods on the same mesh, so
their strain energies bracket the exact one (with loads prescribed U(1SD) >= U >= U(FEM-Q4);
with displacements prescribed the order reverses). The run's own method counts as one
bound if it is 1SD or FEM-Q4, so the bracket costs one extra solve then, two otherwise.
Summary keys: energy_bracket.{upper, lower, upper_method, lower_method, width,
width_rel, contains_run, extra_runs}.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

from app.config import Config
from app.errors import SolveError
from app.run import RunOptions, run, write_summary

BOUNDS = (("cs-fem", 1, "CS-FEM-1SD"), ("fem-q4", 4, "FEM-Q4"))


def energy_bracket(cfg: Config, opts: RunOptions, summary: dict) -> dict:
    """Run the bound methods the run did not use (in OUT/bracket_<label>) and return the
    energy_bracket summary entry; `summary` is the run's own summary."""
    energies, extra = {}, []
    for method, sd, lab in BOUNDS:
        if summary["label"] == lab:
            energies[lab] = summary["strain_energy"]
            continue
        sub = replace(opts, out=Path(opts.out) / f"bracket_{lab}", method=method, sd=sd,
                      progress_prefix=f"energy bracket {lab}", started=None)
        try:
            energies[lab] = run(cfg, sub)["strain_energy"]
        except SolveError as exc:
            return {"error": f"{lab}: {str(exc).splitlines()[0]}", "extra_runs": extra}
        extra.append(lab)
    (hi_lab, hi), (lo_lab, lo) = sorted(energies.items(), key=lambda kv: -kv[1])
    u = summary["strain_energy"]
    width = hi - lo
    return {"upper": hi, "lower": lo, "upper_method": hi_lab, "lower_method": lo_lab,
            "width": width, "width_rel": width / abs(0.5 * (hi + lo)) if hi + lo else 0.0,
            "contains_run": bool(lo * (1 - 1e-12) <= u <= hi * (1 + 1e-12)),
            "extra_runs": extra}


def add_energy_bracket(cfg: Config, opts: RunOptions, summary: dict) -> dict:
    """summary with the energy_bracket entry, rewritten to OUT/summary.json on rank 0.
    The extra runs' seconds (max over ranks) are the phase timings.energy_bracket, counted
    in timings.total (before, they were in no phase of the run's summary)."""
    from mpi4py import MPI
    from petsc4py import PETSc

    started = time.perf_counter()
    summary["energy_bracket"] = energy_bracket(cfg, opts, summary)
    seconds = PETSc.COMM_WORLD.tompi4py().allreduce(time.perf_counter() - started,
                                                     op=MPI.MAX)
    timings = summary.setdefault("timings", {})
    timings["energy_bracket"] = seconds
    timings["total"] = timings.get("total", 0.0) + seconds
    if PETSc.COMM_WORLD.getRank() == 0:
        write_summary(Path(opts.out), summary)
    return summary
