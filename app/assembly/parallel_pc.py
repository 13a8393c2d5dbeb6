"""Incomplete factorizations on several ranks: PETSc's ICC and ILU are sequential.

`-pc_type icc` or `ilu` on one rank solves (`-ksp_type cg -pc_type icc`), but on several
ranks PETSc stops with `Could not locate a solver type for factorization type ICC and
matrix type mpiaij`: the same command failed on 2 ranks. There they become PETSc's
parallel form of the same preconditioner, block Jacobi with the incomplete factorization
of each rank's diagonal block (`-pc_type bjacobi -sub_pc_type icc`; on one rank that is
the plain ICC), and the options of the factorization (`-pc_factor_levels 1`, ...) go to
the blocks (`-sub_pc_factor_levels 1`).
"""

from __future__ import annotations

from petsc4py import PETSc

SEQUENTIAL_PCS = ("icc", "ilu")
"""Preconditioners PETSc has for sequential matrices only (with its own factorization)."""


def block_jacobi_for_sequential_pc(opts: PETSc.Options, size: int) -> str | None:
    """On several ranks, -pc_type icc / ilu (with PETSc's own factorization) becomes
    -pc_type bjacobi -sub_pc_type icc / ilu, its -pc_factor_* options -sub_pc_factor_*.
    Returns the preconditioner so replaced, or None."""
    pc = opts.getString("pc_type", "")
    solver = opts.getString("pc_factor_mat_solver_type", "petsc")
    if size <= 1 or pc not in SEQUENTIAL_PCS or solver != "petsc":
        return None
    opts.setValue("pc_type", "bjacobi")
    if not opts.hasName("sub_pc_type"):
        opts.setValue("sub_pc_type", pc)
    for key, value in opts.getAll().items():
        if key.startswith("pc_factor_"):
            if not opts.hasName(f"sub_{key}"):
                opts.setValue(f"sub_{key}", value)
            opts.delValue(key)
    return pc
