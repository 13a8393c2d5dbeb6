"""Benchmark: the compliance C = G K^-1 G^T for m = 100, 1000, 3000 pairs on one mesh,
against the factorization of the same matrix. One JSON line per m.

    .venv/bin/python scripts/bench_compliance.py [--mesh-size 0.0045] [--pairs 100 1000 3000]
        [--solve-route-max 100]
    mpiexec --allow-run-as-root -n 2 .venv/bin/python scripts/bench_compliance.py

The mesh is the cantilever (configs/cantilever.toml) at --mesh-size (0.0045: about 10^6
DOFs). The m "pairs" are nodes of the top and bottom edges, each with a normal (y) and a
tangential (x) row, as node-to-segment pairs with xi = 0 give. The Schur route (MUMPS
Schur complement + dense solve on rank 0) is timed for every m; the solve route (one
solve per row with the stored factorization) up to --solve-route-max pairs.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from app.assembly.loads import constrained_dofs
from app.assembly.solve import LinearSolver, apply_dirichlet, set_default_options
from app.assembly.stiffness import assemble_stiffness
from app.condensation.compliance import compliance_schur, compliance_solve
from app.config import load_config
from app.run import RunOptions, build_scene_mesh, collective, make_discretisation, to_numpy_all

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mesh-size", type=float, default=0.0045)
    ap.add_argument("--pairs", type=int, nargs="+", default=[100, 1000, 3000])
    ap.add_argument("--solve-route-max", type=int, default=100)
    args = ap.parse_args()
    if not args.mesh_size > 0 or min(args.pairs) < 1 or args.solve_route_max < 0:
        ap.error("--mesh-size must be > 0, --pairs at least 1, --solve-route-max at least 0")
    comm = PETSc.COMM_WORLD
    rank = comm.getRank()
    cfg = load_config(ROOT / "configs" / "cantilever.toml")
    opts = RunOptions(mesh_scale=args.mesh_size / cfg.mesh_size, quiet=True)
    set_default_options({})
    mesh = collective(build_scene_mesh, cfg, opts)
    disc = make_discretisation(cfg, opts)
    fixed = constrained_dofs(mesh, cfg)
    k = assemble_stiffness(mesh, disc, comm)
    apply_dirichlet(k, fixed)
    solver = LinearSolver(k)
    t0 = time.perf_counter()
    solver.factor()
    t_fact = comm.tompi4py().allreduce(time.perf_counter() - t0, op=_max())
    y = mesh.points[:, 1]
    edge = np.flatnonzero((np.abs(y - y.max()) < 1e-9) | (np.abs(y - y.min()) < 1e-9))
    edge = edge[mesh.points[edge, 0] > 1e-9]  # not on the clamp
    for m in args.pairs:
        if m > edge.size:
            continue
        nodes = edge[np.linspace(0, edge.size - 1, m).astype(int)]
        rows = np.arange(2 * m)
        cols = np.concatenate([2 * nodes + 1, 2 * nodes])
        g = sp.csr_matrix((np.ones(2 * m), (rows, cols)), shape=(2 * m, 2 * mesh.n_nodes))
        t0 = time.perf_counter()
        c1 = compliance_schur(k, g, fixed)
        t_schur = comm.tompi4py().allreduce(time.perf_counter() - t0, op=_max())
        out = {"ranks": comm.getSize(), "n_dofs": 2 * mesh.n_nodes, "pairs": m,
               "factorization_s": round(t_fact, 3), "compliance_schur_s": round(t_schur, 3),
               "schur_over_factorization": round(t_schur / t_fact, 3)}
        if m <= args.solve_route_max:
            t0 = time.perf_counter()
            c2 = compliance_solve(solver, k, g, fixed, to_numpy_all)
            out["compliance_solve_s"] = round(
                comm.tompi4py().allreduce(time.perf_counter() - t0, op=_max()), 3)
            if rank == 0:
                out["routes_max_rel_diff"] = float(np.abs(c1 - c2).max() / np.abs(c2).max())
        if rank == 0:
            print(json.dumps(out), flush=True)


def _max():
    from mpi4py import MPI

    return MPI.MAX


if __name__ == "__main__":
    main()
