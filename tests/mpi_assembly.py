"""Run under `mpiexec -n 2` by tests/test_assembly.py: the compiled and the numpy stiffness
of every variant, compared on every rank. Rank 0 prints one JSON line per rank and variant."""

from __future__ import annotations

import json

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc
from test_assembly import discretisation, two_body_mesh
from test_discretisation import VARIANTS

from app.assembly.stiffness import assemble_stiffness


def main() -> None:
    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    mesh = two_body_mesh()
    for method, sd in VARIANTS:
        disc = discretisation(method, sd)
        a = assemble_stiffness(mesh, disc, comm, route="compiled")
        b = assemble_stiffness(mesh, disc, comm, route="numpy")
        ai, aj, av = a.getValuesCSR()
        bi, bj, bv = b.getValuesCSR()
        x = a.createVecRight()
        x.setRandom()
        ya, yb = a.createVecLeft(), b.createVecLeft()
        a.mult(x, ya)
        b.mult(x, yb)
        scale = mpi.allreduce(np.abs(bv).max(), op=MPI.MAX)
        rows = mpi.gather({
            "rank": comm.getRank(), "method": method, "sd": sd, "type": a.getType(),
            "same_pattern": bool(np.array_equal(ai, bi) and np.array_equal(aj, bj)),
            "value_error": float(np.abs(av - bv).max() / scale),
            "product_error": float((ya - yb).norm() / yb.norm()),
        })
        for row in rows or []:
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
