"""Phases 2 and 3: assemble the stiffness, apply the supports, factor once, and solve the
unit load cases with that factorization."""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from app.assembly.sequential_factor import SequentialCholesky
from app.assembly.solve import (
    LinearSolver,
    SingularStiffnessError,
    apply_dirichlet,
)
from app.assembly.stiffness import assemble_stiffness
from app.condensation.compliance import attach_schur, compliance_route, request_schur
from app.discretisation.bulk import Discretisation, zero_energy_modes
from app.driver.context import RunContext
from app.driver.model import Model
from app.errors import SolveError
from app.mesh.model import Mesh
from app.output.reactions import ReactionProbe
from app.parallel import from_numpy, to_numpy_all


@dataclass
class LinearSystem:
    """The factored stiffness. k: distributed PETSc matrix with the supports applied;
    solver: its one factorization; route: the compliance route (schur | solve, None
    without contact); lifting: K u_d per load case with prescribed displacements (None
    for the others); probe: the reactions of the unconstrained K."""

    k: PETSc.Mat
    solver: LinearSolver
    route: str | None
    lifting: list[np.ndarray | None]
    probe: ReactionProbe


@dataclass
class UnitSolutions:
    """Per load case: u = K^-1 b at factor 1 (2n,), and b itself with the Dirichlet lifting
    and zero on prescribed DOFs (the load on the floating modes); per step, its forces."""

    u: list[np.ndarray]
    rhs: list[np.ndarray]
    step_forces: list[float] | None = None
    """(n_steps,) T(t), the size (2-norm) of the largest load case's forces at each step
    (`step_force_scales`): a step's recoveries are judged against it."""


def assemble_and_factor(ctx: RunContext, model: Model) -> LinearSystem:
    """Phases assembly, boundary_conditions and factorization."""
    with ctx.phase("assembly"):
        k = assemble_stiffness(model.mesh, model.disc, ctx.comm)
    with ctx.phase("boundary_conditions"):
        lifting = []
        for case in model.cases:
            if np.any(case.prescribed):
                kud = k.createVecLeft()
                k.mult(from_numpy(k, case.prescribed), kud)
                lifting.append(to_numpy_all(kud))
            else:
                lifting.append(None)
        probe = ReactionProbe(k, model.fixed)
        apply_dirichlet(k, model.fixed_all)
    with ctx.phase("factorization"):
        solver = LinearSolver(k)
        contact = model.contact
        route = compliance_route(ctx.cfg.compliance, solver) if contact is not None else None
        schur_dofs = request_schur(solver, contact.g, model.fixed_all) \
            if route == "schur" else None
        try:
            solver.factor()
        except SingularStiffnessError as exc:
            raise SolveError(singular_message(model.disc, model.mesh, str(exc),
                                              model.fixed_all)) from None
        if schur_dofs is not None:  # the one factorization serves compliance and solves
            attach_schur(solver, k, schur_dofs)
    return LinearSystem(k, solver, route, lifting, probe)


def unit_solutions(ctx: RunContext, model: Model, system: LinearSystem) -> UnitSolutions:
    """Phase solve: one forward/back substitution per load case."""
    unit, rhs, loads = [], [], []
    free = ~np.isin(np.arange(model.n_dofs), model.fixed)
    for case, kud in zip(model.cases, system.lifting, strict=True):
        b = case.rhs.copy()
        if kud is not None:
            b -= kud
        rhs.append(np.where(free, b, 0.0))
        b[model.fixed_all] = case.prescribed[model.fixed_all]
        loads.append(b)
    scales, run_scale = case_scales(loads, [case.history for case in model.cases])
    system.solver.force_scale = max(system.solver.force_scale, run_scale)
    with ctx.phase("solve"):
        for b, scale in zip(loads, scales, strict=True):
            try:
                x = system.solver.solve(from_numpy(system.k, b), refine=True, scale=scale)
            except SingularStiffnessError as exc:
                raise SolveError(singular_message(model.disc, model.mesh, str(exc),
                                                  model.fixed_all)) from None
            unit.append(to_numpy_all(x))
    warn_solve_accuracy(ctx, system.solver)
    return UnitSolutions(unit, rhs, step_force_scales(
        loads, [c.history for c in model.cases], ctx.cfg.n_steps))


def step_force_scales(loads: list[np.ndarray], histories: list[np.ndarray],
                      n_steps: int) -> list[float]:
    """T(t) = max_j |b_j| |h_j(t)| per step (n_steps,): the size of the forces step t
    applies; loads (2n,) each at factor 1, histories (n_steps,) each (0 without loads)."""
    if not loads:
        return [0.0] * n_steps
    sizes = np.array([float(np.linalg.norm(b)) for b in loads])
    return [float(x) for x in (sizes[:, None] * np.abs(np.stack(histories))).max(axis=0)]


def case_scales(loads: list[np.ndarray], histories: list[np.ndarray]
                ) -> tuple[list[float], float]:
    """(per load case the scale its unit solve's residual is judged against, the run's
    force scale): loads (2n,) each at factor 1, histories (n_steps,) each. A step applies
    forces of size T(t) = max_j |b_j| |h_j(t)|; case k's scale is the smallest
    T(t) / |h_k(t)| over the steps where it acts, so that a residual accepted as round-off
    (`app.assembly.solve.ROUND_OFF_RESIDUAL`) stays round-off of the forces of every step
    that multiplies it. The run's scale is max_t T(t). Judged against the other cases' |b|
    at factor 1 (before), a load of 1e-13 with history [1e13] was solved by -ksp_atol 1e-12
    as x = 0 and dropped without a word; judged against the run's largest forces, a load
    acting in a step of its own would be judged against another step's forces. A case
    whose factors are all 0 is judged against its own |b|."""
    sizes = np.array([float(np.linalg.norm(b)) for b in loads])
    if not sizes.size:
        return [], 0.0
    factors = np.abs(np.stack(histories))  # (cases, steps)
    totals = np.array(step_force_scales(loads, histories, factors.shape[1]))  # T(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(factors > 0, totals[None, :] / factors, np.inf)
    scales = ratio.min(axis=1, initial=np.inf)
    scales = np.where(np.isfinite(scales), np.maximum(scales, sizes), sizes)
    return [float(x) for x in scales], float(totals.max(initial=0.0))


def warn_solve_accuracy(ctx: RunContext, solver: LinearSolver) -> None:
    """Once per run: a warning when an iterative solve so far was accepted with a relative
    residual that the contact states and figures cannot carry (`accuracy_warning`)."""
    text = solver.accuracy_warning()
    if text is not None:
        ctx.warn(text, ("solve accuracy",))


def singular_message(disc: Discretisation, mesh: Mesh, detail: str,
                     fixed: np.ndarray | None = None) -> str:
    """Name the bodies whose stiffness keeps zero-energy modes under their supports.

    When every body was analysed, MUMPS's null-pivot count in `detail` is replaced by the
    number of zero-energy modes found: the pivot count depends on how the matrix is
    distributed (hourglass_1sd.toml at --mesh-size 2.0: 2 on 1 rank, 1 on 3 or 4)."""
    names, n_modes, analysed = [], 0, fixed is not None
    if fixed is not None:
        for b in range(len(mesh.body_names)):
            r = _mode_count(mesh, disc, b, fixed)
            if r is None:
                analysed = False
                continue
            n_modes += r
            if r > 0:
                names.append(f"'{mesh.body_names[b]}'")
    if analysed and n_modes > 0:
        detail = MUMPS_PIVOTS.sub(f"({n_modes} zero-energy modes)", detail)
    where = f" in body {', '.join(names)}" if names else ""
    if disc.hourglass:
        return (f"{detail}: {disc.label} has hourglass (zero-energy) modes{where} that the "
                "supports do not suppress; use --sd 2 or more (hourglass-free smoothing) or "
                "--method fem-q4")
    return f"{detail}: check that every body is held by supports{where}" + \
        _incompressible_hint(disc, mesh)


def _mode_count(mesh: Mesh, disc: Discretisation, body: int, fixed: np.ndarray) -> int | None:
    """The number of zero-energy modes of one body under `fixed`, or None where it is not
    known: a body over 20,000 elements, or an eigen-solve that does not settle. The count
    only words the message of a solve that already failed, so its own failure must not
    replace that message (the cantilever at nu = 0.4999999999, clamp at zero, stopped with
    "the zero-energy modes of body 'beam' did not converge" instead of the
    incompressibility hint while the eigen-solve tested |K v| for convergence)."""
    if np.sum(mesh.body == body) > 20000:
        return None
    try:
        return zero_energy_modes(mesh, disc, body, fixed,
                                 factorize=SequentialCholesky).shape[1]
    except SolveError:
        return None


MUMPS_PIVOTS = re.compile(r"\(\d+ null pivots in MUMPS\)")
"""MUMPS's null-pivot count in a SingularStiffnessError's text (app/assembly/solve.py)."""

INCOMPRESSIBLE_RATIO = 1e5
"""lambda / mu from which a body is named as a likely cause of an inaccurate solve (nu
= 0.49999999 in plane strain, 5e7, failed on cantilever.toml; 0.4999999, 5e6, solved)."""


def _incompressible_hint(disc: Discretisation, mesh: Mesh) -> str:
    """'; or ...' naming the nearly incompressible plane-strain bodies, else ''."""
    if disc.plane != "strain":
        return ""
    nu = np.asarray(disc.nu, dtype=float)
    ratio = 2.0 * nu / np.maximum(1.0 - 2.0 * nu, 1e-300)  # lambda / mu
    worst = int(np.argmax(ratio))
    if ratio[worst] < INCOMPRESSIBLE_RATIO:
        return ""
    return (f"; or nu = {nu[worst]:.10g} in body '{mesh.body_names[worst]}' is nearly "
            f"incompressible (plane strain, lambda/mu = {ratio[worst]:.2g}) and the stiffness "
            "too ill-conditioned to solve: use a smaller nu")
