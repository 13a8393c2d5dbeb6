"""Options-driven linear solves with one factorization of the stiffness.

Defaults: KSP preonly + LU with MUMPS and MUMPS null-pivot detection (ICNTL(24) = 1) so
that a singular stiffness is reported instead of solved. Anything can be overridden
with PETSc options (command line or the config's [petsc] table), e.g.
`-ksp_type cg -pc_type gamg` or `-pc_factor_mat_solver_type superlu_dist`.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from app import hard_stop
from app.assembly.parallel_pc import block_jacobi_for_sequential_pc
from app.errors import SolveError

DEFAULT_OPTIONS = {
    "ksp_type": "preonly",
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "mumps",
    "mat_mumps_icntl_24": "1",
}

FACTOR_DEFAULTS = ("pc_factor_mat_solver_type", "mat_mumps_icntl_24")
"""The defaults that apply only to a full factorization (-pc_type lu or cholesky)."""

ITERATIVE_RTOL = "1e-12"
"""Default -ksp_rtol of an iterative KSP (one other than preonly) unless the user gave one.
PETSc's own 1e-5 leaves displacement errors far above what the contact compliance and the
LCP's gap checks resolve (the compliance is a difference of displacements)."""

DIRECT_PCS = ("lu", "cholesky", "qr", "redundant", "svd")
"""Preconditioners that solve K x = b on their own (with -ksp_type preonly)."""

ACCEPTED_RESIDUAL = 1e-6
"""Largest relative residual |b - K x| / |b| a solve may return."""


class SingularStiffnessError(SolveError):
    """The stiffness itself is singular (null pivots, NaN, or a direct solve that is
    inaccurate): the driver names the bodies that keep zero-energy modes."""


def _start_log_view(opts: PETSc.Options, value: str | None) -> None:
    """`log_view` from the config's [petsc] table (`true`, `""` or a viewer such as
    `":log.txt"`). PETSc reads -log_view only at start-up; given later it must start the
    log itself, else PetscFinalize fails ("Must use -log_view ...") and the option is
    reported unused. The command line wins."""
    if value is None or opts.hasName("log_view") or value.strip().lower() == "false":
        return
    opts.setValue("log_view", "" if value.strip().lower() == "true" else value)
    PETSc.Log.begin()
    opts.getString("log_view", "")  # read now: PetscFinalize prints the log


def set_default_options(extra: dict[str, str] | None = None) -> None:
    """Put defaults, then the config's [petsc] table, into the options database.

    Options already given on the command line win over both.
    """
    opts = PETSc.Options()
    extra = dict(extra or {})
    _start_log_view(opts, extra.pop("log_view", None))
    for table in (extra, DEFAULT_OPTIONS):
        for key, value in table.items():
            if table is DEFAULT_OPTIONS and key in FACTOR_DEFAULTS and opts.getString(
                    "pc_type", "lu") not in ("lu", "cholesky"):
                continue  # MUMPS is no solver type of ILU, ICC, ...: PETSc would refuse it
            if not opts.hasName(key):
                opts.setValue(key, value)
    block_jacobi_for_sequential_pc(opts, PETSc.COMM_WORLD.getSize())  # icc, ilu: sequential
    ksp_type = opts.getString("ksp_type", "preonly")
    if ksp_type != "preonly" and not opts.hasName("ksp_rtol"):
        opts.setValue("ksp_rtol", ITERATIVE_RTOL)


def apply_dirichlet(k: PETSc.Mat, dofs: np.ndarray) -> None:
    """Zero the rows and columns of prescribed DOFs and put 1 on their diagonal."""
    r0, r1 = k.getOwnershipRange()
    own = dofs[(dofs >= r0) & (dofs < r1)].astype(PETSc.IntType)
    k.zeroRowsColumns(own, diag=1.0)


def _schur_hint(f: PETSc.Mat, info: int) -> str:
    """What to try when MUMPS refused a factorization with a Schur set (ICNTL(19) on, the
    default compliance route): some -mat_mumps_icntl_* values, e.g. ICNTL(28) = 2 (parallel
    analysis, INFOG(1) = -39), are incompatible with it; the solve route needs no Schur set."""
    if info == -10 or f.getMumpsIcntl(19) == 0:
        return ""
    return ("; MUMPS refuses this factorization with the Schur complement of the default "
            "compliance route (ICNTL(19)): run with -contact_compliance solve, or leave out "
            "the -mat_mumps_icntl_* option that conflicts with it")


class LinearSolver:
    """One factorization of K (after Dirichlet elimination), reused for every solve."""

    def __init__(self, k: PETSc.Mat):
        self.k = k
        self.ksp = PETSc.KSP().create(comm=k.getComm())
        self.ksp.setOperators(k)
        self.ksp.setFromOptions()
        self.is_mumps = False
        self.block = None  # a solver on the factor (e.g. SchurFactorization) used instead
        self.iterative = self.ksp.getType() != "preonly"
        pc = self.ksp.getPC()
        if pc.getType() in ("lu", "cholesky"):
            self.is_mumps = pc.getFactorSolverType() == "mumps"
        # MUMPS's Schur complement of a Cholesky (symmetric) factor is not the full S
        # (C came out wrong), so the Schur route needs its LU.
        self.is_mumps_lu = self.is_mumps and pc.getType() == "lu"
        self.pc_type = pc.getType()

    def factor(self) -> None:
        """Symbolic + numeric factorization (or preconditioner set-up)."""
        with hard_stop.armed():  # one C call that holds the GIL
            self.ksp.setUp()
        if self.is_mumps:
            f = self.ksp.getPC().getFactorMatrix()
            null = f.getMumpsInfog(28)
            if null > 0:
                raise SingularStiffnessError(f"stiffness is singular ({null} null pivots in MUMPS)")
            info = f.getMumpsInfog(1)
            if info < 0:
                error = SingularStiffnessError if info == -10 else SolveError
                raise error(f"MUMPS factorization failed (INFOG(1) = {info})"
                            + _schur_hint(f, info))

    def _check_overflow(self, b: PETSc.Vec) -> None:
        """After a NaN solution: SolveError if the same solve with b scaled to a unit
        maximum is finite (the answer overflows float64; the stiffness is not singular)."""
        scale = b.norm(PETSc.NormType.NORM_INFINITY)
        if not scale > 0:
            return
        unit, y = b.copy(), self.k.createVecLeft()
        unit.scale(1.0 / scale)
        try:
            if self.block is not None:
                self.block.solve(unit, y)
            else:
                self.ksp.solve(unit, y)
            finite = np.isfinite(y.norm(PETSc.NormType.NORM_INFINITY))
        finally:
            unit.destroy()
            y.destroy()
        if finite:
            raise SolveError(f"the displacements overflow float64 (largest nodal load "
                             f"{scale:.3g}): a load, body force or prescribed value is out "
                             "of range; check their values and units")

    def solve(self, b: PETSc.Vec, x: PETSc.Vec | None = None,
              forces: np.ndarray | None = None) -> PETSc.Vec:
        """Solve K x = b; checks convergence and the residual. forces: b = G^T forces
        (the contact-force recovery), for the block solver's kept columns.

        A direct solve that is inaccurate or NaN means a singular stiffness
        (SingularStiffnessError); an iterative one that stops short is a SolveError that
        says so and names the options to change.
        """
        x = x or self.k.createVecLeft()
        if not np.isfinite(b.norm(PETSc.NormType.NORM_INFINITY)):  # (NaN x: "singular")
            raise SolveError("the load vector of a linear solve is not finite (inf or NaN): "
                             "a load, body force or prescribed value exceeds the range of "
                             "float64; check their values and units")
        self._check_reason(self._apply(b, x, forces))
        bn, rn = self._residual_norms(b, x)
        if np.isnan(x.norm()):
            self._check_overflow(b)
            raise SingularStiffnessError("linear solve produced NaN: the stiffness is "
                                         "probably singular")
        if bn > 0 and rn > ACCEPTED_RESIDUAL * bn and not np.isnan(bn):
            raise self._inaccurate(rn / bn)
        return x

    def _apply(self, b: PETSc.Vec, x: PETSc.Vec, forces: np.ndarray | None = None) -> int:
        """x = K^-1 b by the block solver or the KSP; the KSP's converged reason (0 for
        the block solver)."""
        with hard_stop.armed():  # one C call that holds the GIL
            if self.block is not None:
                self.block.solve(b, x, forces)
                return 0
            self.ksp.solve(b, x)
            return self.ksp.getConvergedReason()

    def _check_reason(self, reason: int) -> None:
        """SolveError for a negative KSP converged reason (diverged or stopped short)."""
        if reason < 0 and self.iterative:
            raise SolveError(
                f"iterative linear solve did not converge (KSP reason {reason}, "
                f"{self.ksp.getIterationNumber()} iterations): raise -ksp_max_it, change "
                "-ksp_type/-pc_type, or use the default MUMPS LU")
        if reason < 0:
            raise SolveError(f"linear solver diverged (KSP reason {reason}): try other "
                             "PETSc options or the default MUMPS LU")

    def _residual_norms(self, b: PETSc.Vec, x: PETSc.Vec) -> tuple[float, float]:
        """(|b|, |b - K x|), 2-norms."""
        r = b.duplicate()
        self.k.mult(x, r)
        r.aypx(-1.0, b)
        bn, rn = b.norm(), r.norm()
        r.destroy()
        return bn, rn

    def _inaccurate(self, rel: float) -> SolveError:
        """The error of a solve whose relative residual rel exceeds ACCEPTED_RESIDUAL:
        an iterative KSP's tolerance, a preconditioner that is no full factorization, or
        (a direct solve) a singular stiffness."""
        if self.iterative:
            return SolveError(
                f"iterative linear solve is inaccurate (relative residual "
                f"{rel:.2e} > {ACCEPTED_RESIDUAL:g}, -ksp_rtol "
                f"{self.ksp.getTolerances()[0]:g}): lower -ksp_rtol or use the default "
                "MUMPS LU")
        if self.pc_type not in DIRECT_PCS:
            return SolveError(
                f"linear solve is inaccurate (relative residual {rel:.2e}): "
                f"-ksp_type preonly applies -pc_type {self.pc_type} once, which solves "
                "only if it is a full factorization: use -pc_type lu (or cholesky), or "
                "an iterative -ksp_type such as cg")
        return SingularStiffnessError(
            f"linear solve is inaccurate (relative residual {rel:.2e}): the "
            "stiffness is probably singular"
        )
