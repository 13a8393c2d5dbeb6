"""Benchmark: one plain MUMPS factorization against the one factorization with the Schur set
that serves the compliance and the solves (and the older route: a plain factorization plus
a second one for the Schur complement), in time and peak memory.

    .venv/bin/python scripts/bench_factorization.py [--config configs/hertz.toml]
        [--mesh-size 0.0245] [--mesh-cache DIR] [--ranks 1] [--routes plain schur two]

Each route runs in its own process (under mpiexec for --ranks > 1), so that its peak
resident memory (VmHWM, summed over ranks) is its own. The scene's mesh, pairs, supports
and floating-body pins are those of `python -m app run`. Per route, seconds (max over
ranks):
- plain: `factorization` (MUMPS LU), `solve` (one full solve);
- schur: `factorization` (MUMPS LU with the Schur set, `mumps_with_schur_set`, then S
  taken out and factorized densely, `schur_dense_factorization`),
  `compliance` (C = G_c S^-1 G_c^T), `solve` (one full solve by block elimination),
  `recovery` (one solve of K^-1 G^T lambda);
- two: `factorization` (plain), `compliance` (the separate Schur factorization).
CPU seconds (process time, max over ranks) are printed beside the wall-clock ones: on a
busy machine they vary far less. Prints one JSON line per route and run, then one with
the ratios schur / plain (each route's fastest run with --repeat): time (wall and CPU) of
factorization + compliance, peak memory of the process, and peak memory above what the
process held before the factorization.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app_runner import ENV, ROOT, failure_reason

if TYPE_CHECKING:
    import numpy as np

sys.path.insert(0, str(ROOT))  # this checkout's app, not another one installed in .venv


def _peak_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    return 0.0


def run_route(args) -> None:
    """One route in this process; prints its JSON line on rank 0."""
    from petsc4py import PETSc

    from app.assembly.solve import LinearSolver

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    mesh, contact, k, fixed_all = _route_problem(args)
    timed = _Timed(comm)
    before = mpi.allreduce(_peak_mb())
    solver = LinearSolver(k)
    b = k.createVecLeft()
    b.setRandom()
    _time_route(args.route, timed, solver, k, b, contact, fixed_all)
    peak = mpi.allreduce(_peak_mb())
    if comm.getRank() == 0:
        print(json.dumps({
            "route": args.route, "ranks": comm.getSize(), "n_dofs": 2 * mesh.n_nodes,
            "n_pairs": contact.pairs.n_pairs, "seconds": {k: round(v, 3) for k, v in
                                                          timed.times.items()},
            "cpu_seconds": {k: round(v, 3) for k, v in timed.cpu.items()},
            "peak_memory_mb": round(peak, 1), "peak_before_factorization_mb": round(before, 1),
        }), flush=True)


def _route_problem(args: argparse.Namespace) -> tuple:
    """The scene of `python -m app run` for --config / --mesh-size / --mesh-cache:
    (mesh, ContactSetup, stiffness with the supports and floating pins applied, those
    constrained DOFs)."""
    import numpy as np
    from petsc4py import PETSc

    from app.assembly.loads import constrained_dofs
    from app.assembly.solve import apply_dirichlet, set_default_options
    from app.assembly.stiffness import assemble_stiffness
    from app.config import load_config
    from app.interface.contact import ContactSetup
    from app.interface.floating import floating_modes
    from app.run import RunOptions, build_scene_mesh, collective, make_discretisation

    cfg = load_config(Path(args.config))
    opts = RunOptions(mesh_scale=args.mesh_size / cfg.mesh_size if args.mesh_size else 1.0,
                      mesh_cache=Path(args.mesh_cache) if args.mesh_cache else None,
                      quiet=True)
    set_default_options(cfg.petsc)
    mesh = collective(build_scene_mesh, cfg, opts)
    disc = make_discretisation(cfg, opts)
    contact = ContactSetup.build(mesh, cfg)
    fixed = constrained_dofs(mesh, cfg)
    floating = floating_modes(mesh, cfg, fixed, contact, disc)
    pins = floating.pins if floating else np.zeros(0, dtype=np.int64)
    fixed_all = np.union1d(fixed, pins)
    k = assemble_stiffness(mesh, disc, PETSc.COMM_WORLD)
    apply_dirichlet(k, fixed_all)
    return mesh, contact, k, fixed_all


class _Timed:
    """Calls timed between barriers: wall and CPU seconds, max over ranks, by name."""

    def __init__(self, comm: Any) -> None:
        self.comm, self.mpi = comm, comm.tompi4py()
        self.times: dict[str, float] = {}
        self.cpu: dict[str, float] = {}

    def __call__(self, name: str, fn: Callable, *a: Any) -> Any:
        """fn(*a), timed as `name`; returns its result."""
        self.comm.barrier()
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn(*a)
        c1 = time.process_time()
        self.comm.barrier()
        self.times[name] = self.mpi.allreduce(time.perf_counter() - t0, op=_max())
        self.cpu[name] = self.mpi.allreduce(c1 - c0, op=_max())
        return out


def _time_route(route: str, timed: _Timed, solver: Any, k: Any, b: Any, contact: Any,
                fixed_all: np.ndarray) -> None:
    """The timed steps of one route (module docstring) on the stiffness k and a right-hand
    side b; the schur route also records n_schur_dofs in timed.times."""
    import numpy as np

    from app.condensation.compliance import (
        attach_schur,
        compliance_from_factor,
        compliance_schur,
        request_schur,
    )
    from app.condensation.recovery import contact_displacement

    if route == "schur":
        def factor():
            dofs = request_schur(solver, contact.g, fixed_all)
            timed("mumps_with_schur_set", solver.factor)
            timed("schur_dense_factorization", attach_schur, solver, k, dofs)
            return dofs
        dofs = timed("factorization", factor)
        timed.times["n_schur_dofs"] = dofs.size
        timed("compliance", compliance_from_factor, solver, contact.g, fixed_all)
        timed("solve", solver.solve, b)
        lam = np.random.default_rng(0).random(contact.g.shape[0])
        timed("recovery", contact_displacement, contact.g, lam, solver, k, fixed_all, _to_all)
    else:
        timed("factorization", solver.factor)
        timed("solve", solver.solve, b)
        if route == "two":
            timed("compliance", compliance_schur, k, contact.g, fixed_all)


def _to_all(vec):
    from app.run import to_numpy_all

    return to_numpy_all(vec)


def _max():
    from mpi4py import MPI

    return MPI.MAX


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "hertz.toml"))
    ap.add_argument("--mesh-size", type=float, default=0.0245)
    ap.add_argument("--mesh-cache", default=None)
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--routes", nargs="+", default=["plain", "schur", "two"],
                    choices=["plain", "schur", "two"])
    ap.add_argument("--repeat", type=int, default=1,
                    help="run the routes in turn this many times; ratios from each route's "
                         "fastest run")
    ap.add_argument("--route", help=argparse.SUPPRESS)  # internal: run one route here
    args = ap.parse_args()
    if args.route:
        run_route(args)
        return
    if not (ROOT / args.config).is_file():
        ap.error(f"config file '{args.config}' does not exist")
    if args.repeat < 1 or args.ranks < 1 or not args.mesh_size > 0:
        ap.error("--repeat and --ranks must be at least 1 and --mesh-size above 0")
    results: dict[str, list[dict]] = {}
    failed = 0
    for _ in range(args.repeat):
        for route in args.routes:
            cmd = [sys.executable, __file__, "--route", route, "--config", args.config,
                   "--mesh-size", str(args.mesh_size)]
            if args.mesh_cache:
                cmd += ["--mesh-cache", args.mesh_cache]
            if args.ranks > 1:
                cmd = [shutil.which("mpiexec") or "mpiexec", "-n", str(args.ranks), *cmd]
            res = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True)
            if res.returncode != 0:
                print(json.dumps({"route": route, "error": failure_reason(res.stderr)}),
                      flush=True)
                failed += 1
                continue
            line = json.loads(res.stdout.strip().splitlines()[-1])
            results.setdefault(route, []).append(line)
            print(json.dumps(line), flush=True)
    if "plain" in results and "schur" in results:
        def best(route, kind="seconds"):
            return min(r[kind]["factorization"] + r[kind].get("compliance", 0.0)
                       for r in results[route])

        def mem(route, above=False):
            return min(r["peak_memory_mb"] - (r["peak_before_factorization_mb"] if above
                                              else 0.0) for r in results[route])
        print(json.dumps({
            "runs_per_route": args.repeat,
            "schur_over_plain_time": round(best("schur") / best("plain"), 3),
            "schur_over_plain_cpu_time": round(best("schur", "cpu_seconds")
                                               / best("plain", "cpu_seconds"), 3),
            "schur_over_plain_peak_memory": round(mem("schur") / mem("plain"), 3),
            "schur_over_plain_memory_above_assembly": round(
                mem("schur", True) / mem("plain", True), 3),
        }), flush=True)
    raise SystemExit(1 if failed else 0)


if __name__ == "__main__":
    main()
