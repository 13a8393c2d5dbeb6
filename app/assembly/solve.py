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

ROUND_OFF_RESIDUAL = 1e-12
"""A residual |b - K x| at most this times the scale of the run's right-hand sides of its
kind (`LinearSolver.solve`'s `scale`: for a load case the forces of the steps it acts
in, for a step's contact-force recovery that step's forces, `app.driver.linear`) is
round-off of the problem and accepted whatever |b| is: a recovery of round-off contact
forces (|b| = 5.9e-12 on bonded.toml at --mesh-size 0.8, loads 23.1) was solved by
-ksp_atol 1e-12 as x = 0, relative residual 1, and stopped the run. The default
-ksp_rtol (ITERATIVE_RTOL) asks no more of the load solves themselves."""

REFINED_RESIDUAL = 1e-14
"""Relative residual that `LinearSolver.solve(refine=True)` takes an iterative solve at
-ksp_rtol ITERATIVE_RTOL (or tighter) towards (`_refine`): near a direct solve's round-off."""

CORRECTION_MARGIN = 0.01
"""A refinement's correction solve aims this factor below the reduction still needed."""

MAX_REFINEMENTS = 3
"""Refinement solves per solve at most (each must halve the residual, else it stops)."""

LOOSE_RESIDUAL = 1e-9
"""Relative residual above which a run's iterative solves get a warning (`accuracy_warning`):
bonded.toml at --mesh-size 0.8 with -ksp_type cg -pc_type gamg -ksp_rtol 1e-6 (residuals up
to 2.6e-6, accepted) ended step 15 with a pair open instead of slipping, without a word;
the contact states are judged at 1e-7 of the displacement scale."""

STOPPING_OPTIONS = {1: "ksp_rtol", 2: "ksp_rtol", 3: "ksp_atol", 9: "ksp_atol", 4: "ksp_max_it"}
"""The option whose tolerance stopped a KSP, by its converged reason (RTOL_NORMAL, RTOL,
ATOL, ATOL_NORMAL, ITS)."""

REASON_NAMES = {v: k for k, v in vars(PETSc.KSP.ConvergedReason).items()
                if not k.startswith("_") and isinstance(v, int) and v < 0}
"""PETSc's names of the negative KSP converged reasons (DIVERGED_MAX_IT, ...)."""


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


def _tighten(option: str) -> str:
    """What to do with the option that stopped a KSP too early (`-ksp_rtol 1e-06`)."""
    name = option.split()[0]
    return f"raise {name}" if name == "-ksp_max_it" else f"lower {name}"


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
        # an iterative KSP asked for the default accuracy or better: solve(refine=True)
        # refines to round-off
        self.refinable = self.iterative and self.ksp.getTolerances()[0] <= float(ITERATIVE_RTOL)
        pc = self.ksp.getPC()
        if pc.getType() in ("lu", "cholesky"):
            self.is_mumps = pc.getFactorSolverType() == "mumps"
        # MUMPS's Schur complement of a Cholesky (symmetric) factor is not the full S
        # (C came out wrong), so the Schur route needs its LU.
        self.is_mumps_lu = self.is_mumps and pc.getType() == "lu"
        self.pc_type = pc.getType()
        self.worst_residual = 0.0  # largest relative residual of a solve returned so far
        self.worst_option = ""  # the option that stopped that solve (`stopping_option`)
        self.reason = 0  # the KSP's converged reason of the last solve
        self.force_scale = 0.0  # largest |b| of the solves with the default scale (forces)

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
              forces: np.ndarray | None = None, refine: bool = False,
              scale: float | None = None) -> PETSc.Vec:
        """Solve K x = b; checks convergence and the residual. forces: b = G^T forces
        (the contact-force recovery), for the block solver's kept columns. refine: an
        iterative KSP at the default -ksp_rtol (or tighter) goes on to round-off
        (`_refine`): for the free displacements, from which the LCP's data come.
        scale: the size (2-norm) of this kind of right-hand side in the run, against which
        a residual up to ROUND_OFF_RESIDUAL x scale is round-off (`_relative`); None: the
        run's forces, the largest |b| of such solves so far (`force_scale`: the forces
        the steps apply, set by `app.driver.linear.unit_solutions` (the load cases pass
        their own scale), then the contact-force recoveries).

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
        if refine and self.refinable and self.block is None and rn > REFINED_RESIDUAL * bn:
            rn = self._refine(b, x, bn, rn)
        if np.isnan(x.norm()):
            self._check_overflow(b)
            raise SingularStiffnessError("linear solve produced NaN: the stiffness is "
                                         "probably singular")
        if scale is None:
            self.force_scale = scale = max(self.force_scale, bn)
        rel = self._relative(bn, rn, scale)
        if rel > ACCEPTED_RESIDUAL:
            raise self._inaccurate(rel)
        if rel > self.worst_residual:
            self.worst_residual = rel
            self.worst_option = self.stopping_option() if self.iterative else ""
        return x

    @staticmethod
    def _relative(bn: float, rn: float, scale: float) -> float:
        """The residual rn = |b - K x| judged: relative to |b| = bn, or, when it is round-off
        of the run's right-hand sides of this kind (rn <= ROUND_OFF_RESIDUAL x scale),
        relative to scale (a round-off b, |b| itself below that, is solved by x = 0 as well
        as by any x: an absolute -ksp_atol above |b| returns x = 0). 0 when b = 0."""
        if not bn > 0 or np.isnan(bn):
            return 0.0
        if rn <= ROUND_OFF_RESIDUAL * scale:
            return min(rn / bn, rn / scale)
        return rn / bn

    def _apply(self, b: PETSc.Vec, x: PETSc.Vec, forces: np.ndarray | None = None) -> int:
        """x = K^-1 b by the block solver or the KSP; the KSP's converged reason (0 for
        the block solver)."""
        with hard_stop.armed():  # one C call that holds the GIL
            if self.block is not None:
                self.block.solve(b, x, forces)
                return 0
            self.ksp.solve(b, x)
            self.reason = self.ksp.getConvergedReason()
            return self.reason

    def _check_reason(self, reason: int) -> None:
        """SolveError for a negative KSP converged reason (diverged or stopped short)."""
        if reason < 0 and self.iterative:
            raise SolveError(
                f"iterative linear solve did not converge (KSP reason {reason} "
                f"{REASON_NAMES.get(reason, '')}, {self.ksp.getIterationNumber()} "
                f"iterations): {self._advice(reason)}")
        if reason < 0:
            raise SolveError(f"linear solver diverged (KSP reason {reason}): try other "
                             "PETSc options or the default MUMPS LU")

    def _advice(self, reason: int) -> str:
        """What to change after an iterative solve that ended with a negative reason."""
        ksp, pc = self.ksp.getType(), self.pc_type
        if reason == -3:  # DIVERGED_MAX_IT
            return (f"raise -ksp_max_it ({self.ksp.getTolerances()[3]}), change "
                    "-ksp_type/-pc_type, or use the default MUMPS LU")
        if reason in (-8, -10):  # an indefinite preconditioner or matrix for CG
            return (f"-ksp_type {ksp} needs a symmetric positive definite preconditioner, "
                    f"and -pc_type {pc} is not one for this stiffness: use -pc_type gamg, "
                    "icc or jacobi, -ksp_type gmres, or the default MUMPS LU")
        return (f"-ksp_type {ksp} with -pc_type {pc} broke down on this stiffness: change "
                "-ksp_type/-pc_type or use the default MUMPS LU")

    def _refine(self, b: PETSc.Vec, x: PETSc.Vec, bn: float, rn: float) -> float:
        """Iterative refinement of x in place, x += K^-1 (b - K x) with the KSP, while the
        true residual |b - K x| halves, up to MAX_REFINEMENTS times or REFINED_RESIDUAL;
        returns the final |b - K x|. Each correction solve needs only the reduction that
        is left (its -ksp_rtol relaxed to CORRECTION_MARGIN x that, never below the KSP's own).

        Why: the KSP's rtol applies to its own residual (GMRES's preconditioned one), and
        a true relative residual near 1e-12 left an error in the free displacements that
        reached the LCP's data: bonded.toml at --mesh-size 0.8 with -ksp_type gmres
        -pc_type bjacobi failed at step 16 (a tangential motion of +-1e-13 where the
        exact one is 0, which Lemke could not resolve)."""
        rtol, atol, dtol, max_it = self.ksp.getTolerances()
        r, d, best = b.duplicate(), x.duplicate(), x.copy()
        try:
            for _ in range(MAX_REFINEMENTS):
                self.k.mult(x, r)
                r.aypx(-1.0, b)  # r = b - K x
                self.ksp.setTolerances(rtol=max(rtol, min(
                    CORRECTION_MARGIN * REFINED_RESIDUAL * bn / rn, 0.1)))
                with hard_stop.armed():
                    self.ksp.solve(r, d)
                if self.ksp.getConvergedReason() < 0:
                    break
                x.axpy(1.0, d)
                _, new = self._residual_norms(b, x)
                if not new < 0.5 * rn:
                    best.copy(x)  # no gain: keep the better x
                    break
                rn = new
                x.copy(best)
                if rn <= REFINED_RESIDUAL * bn:
                    break
        finally:
            self.ksp.setTolerances(rtol=rtol, atol=atol, divtol=dtol, max_it=max_it)
            for v in (r, d, best):
                v.destroy()
        return rn

    def stopping_option(self) -> str:
        """The option and value that stopped the last KSP solve (`-ksp_atol 1e-06`), by its
        converged reason; -ksp_rtol when the reason names none."""
        rtol, atol, _, max_it = self.ksp.getTolerances()
        name = STOPPING_OPTIONS.get(self.reason, "ksp_rtol")
        value = {"ksp_rtol": rtol, "ksp_atol": atol, "ksp_max_it": max_it}[name]
        return f"-{name} {value:g}"

    def accuracy_warning(self) -> str | None:
        """A warning when an iterative solve of the run was returned with a relative residual
        above LOOSE_RESIDUAL (accepted up to ACCEPTED_RESIDUAL), else None."""
        if not self.iterative or not self.worst_residual > LOOSE_RESIDUAL:
            return None
        return (f"the iterative linear solves reached a relative residual of only "
                f"{self.worst_residual:.2e} ({self.worst_option}): displacements, forces and "
                "contact states carry errors of about that size (states are told apart at "
                f"1e-7 of the displacements); {_tighten(self.worst_option)} (the default "
                f"-ksp_rtol {ITERATIVE_RTOL} is refined to round-off) or use the default "
                "MUMPS LU")

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
            option = self.stopping_option()
            return SolveError(
                f"iterative linear solve is inaccurate (relative residual "
                f"{rel:.2e} > {ACCEPTED_RESIDUAL:g}, {option}): {_tighten(option)} or "
                "use the default MUMPS LU")
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
