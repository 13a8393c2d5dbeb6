"""Phases 4 and 5 with contact: condense onto the contact rows (C = G K^-1 G^T), and solve
each load step's LCP on rank 0 with the consistency refinement against the displacement
recovered from the stored factorization."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from app.assembly.solve import LinearSolver
from app.condensation.compliance import compliance_from_factor, compliance_solve
from app.condensation.recovery import contact_displacement, mismatch
from app.contact.master_penetration import (
    master_penetration_warning,
    penetration,
    penetration_watch,
)
from app.contact.resolution import stripe_checks, stripe_warning
from app.contact.unpaired import Watch, crossing, crossing_warning, unpaired_watch
from app.driver.context import RunContext, write_summary
from app.driver.linear import LinearSystem, UnitSolutions, warn_solve_accuracy
from app.driver.model import Model
from app.driver.rank0_solve import on_rank0_solve
from app.errors import SolveError
from app.interface.floating import HOURGLASS_HINT, held_text
from app.interface.steps import ContactStepper, StepSolution
from app.interface.weak_modes import slide_warning
from app.output.contact import consistency_scales, pair_scales_of
from app.output.pair_law import EPS, PAIR_WARN, ROUNDOFF_ULPS
from app.output.status import writing
from app.parallel import collective, to_numpy_all

if TYPE_CHECKING:
    import scipy.sparse as sp

CONSISTENCY_TOL = 1e-9
"""Largest |G u - LCP kinematics| / max |u| accepted without a refinement re-solve."""
MAX_REFINEMENTS = 5
"""Consistency re-solves per step at most (each: one LCP solve and one back-substitution)."""


@dataclass
class ContactStep:
    """One solved load step: u (2n,) the displacement with the contact forces, the
    stepper's solution (rank 0's, broadcast), and the linear solves' relative residual
    if iterative (0 for a direct solve: the per-pair checks' round-off floor)."""

    u: np.ndarray
    result: StepSolution
    solve_rel: float = 0.0


def condense(ctx: RunContext, model: Model, system: LinearSystem,
             unit: UnitSolutions) -> ContactStepper | None:
    """Phases compliance and lcp (the LCP matrix, built once): the rank-0 stepper."""
    contact = model.contact
    with ctx.phase("compliance"):
        if system.route == "schur":
            gaps = contact.pairs.g0 / np.maximum(contact.pairs.length, 1e-300)
            c_mat = compliance_from_factor(system.solver, contact.g, model.fixed_all,
                                           np.argsort(gaps, kind="stable"))
        else:
            c_mat = compliance_solve(system.solver, system.k, contact.g, model.fixed_all,
                                     to_numpy_all)
    ctx.summary["compliance_route"] = system.route
    warn_solve_accuracy(ctx, system.solver)
    with ctx.phase("lcp"):  # rank 0's stepper (None elsewhere); its errors on every rank
        return on_rank0_solve(contact.stepper, c_mat, model.cases, unit.u, unit.rhs,
                              model.floating)


def solve_contact_step(ctx: RunContext, model: Model, system: LinearSystem,
                       stepper: ContactStepper | None, step: int,
                       u_free: np.ndarray, step_force: float | None = None) -> ContactStep:
    """Load step `step` (0-based): the LCP, the displacement, and up to MAX_REFINEMENTS
    consistency re-solves while |G u - LCP kinematics| halves. SolveError (with the
    summary written) when the LCP has no solution. step_force: the size of the forces
    the step applies (`UnitSolutions.step_forces`), against which the recoveries'
    residuals are judged (None: the run's largest forces, as before)."""
    with ctx.phase("lcp"):
        result = collective(lambda: stepper.step(step, model.cases))  # on every rank
    if not result.solved:
        with ctx.phase("lcp"):  # the diagnosis and the failed summary: in the LCP's seconds
            _fail(ctx, model, step, result, system.solver)
    correction = np.zeros(2 * model.contact.pairs.n_pairs) if ctx.rank == 0 else None
    refinements, previous = 0, np.inf
    while True:
        with ctx.phase("recovery"):
            u = _displacement(model, system, u_free, result, step_force)
            miss, figure, worst, again = _consistency(ctx, model, u, result, refinements,
                                                      previous, solve_rel(system.solver),
                                                      u_free)
            if not again:  # the step's answer: its checks, in the same phase
                _answer_checks(ctx, model, result, step, refinements, figure, u)
        if not again:
            break
        previous = worst
        with ctx.phase("lcp"):
            if ctx.rank == 0:
                correction += miss
            retry = collective(lambda c=correction: stepper.refine(step, model.cases, c))
        if retry is None:
            with ctx.phase("recovery"):
                _answer_checks(ctx, model, result, step, refinements, figure, u)
            break
        result = retry
        refinements += 1
    warn_solve_accuracy(ctx, system.solver)
    return ContactStep(u, result, solve_rel(system.solver))


def solve_rel(solver: LinearSolver) -> float:
    """The relative residual of the linear solves so far if iterative, else 0: what the
    displacements carry beyond round-off (`app.output.pair_law.kinematic_floor`)."""
    return float(solver.worst_residual) if solver.iterative else 0.0


def _crossing_warnings(ctx: RunContext, model: Model, u: np.ndarray, step: int) -> None:
    """A warning the first time slave nodes without a pair have moved through an
    interface's master, or master nodes through its slave (app/contact/unpaired.py,
    master_penetration.py); every rank holds the same u. The undeformed half of both
    checks is built at the first step and kept in `model.watches`."""
    for itf, (unpaired, masters) in zip(ctx.cfg.interfaces, _watches(ctx, model),
                                        strict=True):
        crossed = crossing(unpaired, u.reshape(-1, 2))
        if crossed is not None:
            ctx.warn(crossing_warning(itf.name, step + 1, crossed, itf.search_distance),
                     ("crossing", itf.name))
        behind = penetration(masters, u.reshape(-1, 2))
        if behind is not None:
            slave, master = _sides(model, itf)
            ctx.warn(master_penetration_warning(itf.name, step + 1, slave, master, behind),
                     ("master behind slave", itf.name))


def _sides(model: Model, itf) -> tuple[str, str]:
    """(slave, master) curves of an interface as its pairs have them."""
    on = model.contact.described.get(itf.name, {}).get("pairs_on", itf.slave)
    return (itf.slave, itf.master) if on == itf.slave else (itf.master, itf.slave)


def _watches(ctx: RunContext, model: Model) -> list[tuple[Watch | None, Watch | None]]:
    """Per interface, the Watch of its unpaired slave nodes and of its master nodes, built
    once (the pairs are chosen once, on the undeformed mesh)."""
    if not model.watches:
        pairs = model.contact.pairs
        for i, itf in enumerate(ctx.cfg.interfaces):
            paired = pairs.slave[pairs.interface == i]
            slave, master = _sides(model, itf)
            model.watches.append(
                (unpaired_watch(model.mesh, slave, master, paired, itf.name),
                 penetration_watch(model.mesh, slave, master, itf.name)))
    return model.watches


def _answer_checks(ctx: RunContext, model: Model, result: StepSolution, step: int,
                   refinements: int, figure: float, u: np.ndarray) -> None:
    """The step's final answer (u (2n,) its displacement): its consistency figures in
    `result.info`, and the once-per-run warnings about it."""
    result.info["consistency_refinements"] = refinements
    result.info["lcp_displacement_mismatch"] = figure
    _held_mode_warnings(ctx, result, step, model.contact.described)
    _stripe_warnings(ctx, model, result, step)
    _crossing_warnings(ctx, model, u, step)


def _held_mode_warnings(ctx: RunContext, result: StepSolution, step: int,
                        described: dict) -> None:
    """A warning (summary `warnings`, one stderr line on rank 0) the first time an unloaded
    contact-held mode of a body slid an interface beyond SLIDE_WARN (app/interface/
    weak_modes.py); `steps[k].contact_held_modes` holds every measured ratio."""
    for entry in result.info.get("contact_held_modes", []):
        if entry["warn"]:
            how = described.get(entry["interface"], {}).get("discretisation")
            ctx.warn(slide_warning(entry, step + 1, how),
                     ("contact-held mode", entry["body"], entry["interface"]))


def _stripe_warnings(ctx: RunContext, model: Model, result: StepSolution, step: int) -> None:
    """A warning the first time an interface's tractions follow its master's element
    period (app/contact/resolution.py); every rank holds the broadcast result."""
    pairs, described = model.contact.pairs, model.contact.described
    normal = result.lam[: pairs.n_pairs]
    for check in stripe_checks(model.mesh, pairs, normal, list(described), result.f_scale):
        if check["warn"]:
            name = check["interface"]
            ctx.warn(stripe_warning(check, step + 1, described[name]["discretisation"]),
                     ("stripes", name))


def _displacement(model: Model, system: LinearSystem, u_free: np.ndarray,
                  result: StepSolution, step_force: float | None = None) -> np.ndarray:
    """u_free + K^-1 G^T lambda (+ the floating modes' amplitudes); step_force: the
    step's force scale that the recovery's residual is judged against. Judged against
    the run's largest forces (before), a step of small forces after one of large forces
    accepted a residual far above its own forces' round-off (-ksp_atol). A step that
    applies no forces (0) has no scale of its own: its contact forces come from earlier
    steps or the initial gaps, and are judged against the run's largest forces (judged
    against 0, two_blocks.toml unloaded at step 2 with -ksp_atol 1e-12 stopped on its
    round-off contact forces, solved as x = 0: relative residual 1)."""
    g = model.contact.g
    u_contact = contact_displacement(g, result.lam, system.solver, system.k, model.fixed_all,
                                     to_numpy_all, step_force or None)
    # lam . G K^-1 G^T lam: the bound of the motion a tied pair's dropped compliance row
    # makes (`app.output.pair_law.tied_coupling`)
    result.contact_work = max(float(result.lam @ (g @ u_contact)), 0.0)
    u = u_free + u_contact
    if model.floating is not None and model.floating.r.shape[1]:
        u += model.floating.r @ result.alpha
    return u


def lcp_data_round_off(g: sp.csr_matrix, u_free: np.ndarray, g0: np.ndarray,
                       result: StepSolution) -> float:
    """The round-off of the step's LCP kinematic data, ROUNDOFF_ULPS eps x the largest of
    their terms: the free motion's (|G| |u_free|), the initial gap g0, tau_prev, and the
    motion of the bonds' a and c through each pair's compliance (C_ii a, C_ii c). A
    mismatch G u - LCP kinematics below it is round-off of the LCP's own data, which a
    re-solve (that adds the mismatch to that data) cannot reduce. g (2m, 2n) sparse;
    u_free (2n,); g0 (m,)."""
    diag = np.abs(result.compliance_diag) if result.compliance_diag is not None else 0.0
    sizes = [abs(g) @ np.abs(u_free), np.abs(g0),
             np.abs(result.tau_prev) if result.tau_prev is not None else 0.0]
    if result.a is not None and result.c is not None:
        sizes.append(diag * np.abs(np.concatenate([result.a, result.c])))
    return ROUNDOFF_ULPS * EPS * max(float(np.max(x, initial=0.0)) for x in sizes)


def mismatch_figure(largest: float, u_max: float, floor: float) -> float:
    """`lcp_displacement_mismatch`: max |G u - LCP kinematics| (largest, length) over the
    step's max |u| (u_max), that scale at least floor / CONSISTENCY_TOL (floor: the
    round-off of the LCP's kinematic data, `lcp_data_round_off`), so that a mismatch at
    that round-off reads at most CONSISTENCY_TOL. Over max |u| alone a step with no load
    read round-off over round-off: 1.7e-3 on multibody.toml unloaded after two loaded
    steps (max |u| 7.9e-16). Not over the data's size itself, nor over the unit load
    cases' contact motion (`StepSolution.u_scale`): those are up to 7e3 x a loaded step's
    max |u| on the shipped scenes (aspect_ratio, cattaneo_many) and hid their figures. The
    re-solve decision reads max |u| with that floor (`_consistency`)."""
    return largest / max(u_max, floor / CONSISTENCY_TOL, 1e-300)


def _consistency(ctx: RunContext, model: Model, u: np.ndarray, result: StepSolution,
                 refinements: int, previous: float, accuracy: float,
                 u_free: np.ndarray | None = None):
    """(G u - LCP kinematics on rank 0, the reported figure `mismatch_figure`, the larger
    of max |G u - kinematics| / max |u| over CONSISTENCY_TOL and of each pair's against
    its own scale over PAIR_WARN, whether to re-solve: that measure above 1 and halved
    since the last solve). accuracy: the linear solves' relative residual if iterative,
    else 0 (`solve_rel`). The run-wide part counts only where max |G u - kinematics| is
    above the round-off of the LCP's data (`lcp_data_round_off`, u_free the step's free
    displacement): at a step with no load u is round-off (multibody.toml with every load
    at 0: max |u| 4.1e-16, the mismatch 3.4e-18 = 8.4e-3 of it) and the re-solve was
    wasted."""
    def measure():
        miss = mismatch(model.contact.g, u, result)
        scale = max(np.abs(u).max(initial=0.0), 1e-300)
        largest = float(np.abs(miss).max(initial=0.0))
        rel = largest / scale
        floor = 0.0 if u_free is None else lcp_data_round_off(
            model.contact.g, u_free, model.contact.pairs.g0, result)
        figure = mismatch_figure(largest, scale, floor)
        # each pair against its own scale (`app.output.pair_law`): a stiff interface
        # beside a soft one moves 1e-11 as much, far below CONSISTENCY_TOL of max |u|
        _, _, s = pair_scales_of(model.contact, result, u, model.mesh.node_body(), accuracy)
        own = float((np.abs(miss) / consistency_scales(result, s)).max(initial=0.0))
        worst = max(rel / CONSISTENCY_TOL if largest > floor else 0.0, own / PAIR_WARN)
        again = worst > 1.0 and refinements < MAX_REFINEMENTS and worst < 0.5 * previous
        return miss, figure, worst, again

    miss, figure, worst, again = on_rank0_solve(measure) or (None, None, None, None)
    again, figure, worst = ctx.mpi.bcast((again, figure, worst), root=0)  # (its failure shared)
    return miss, figure, worst, again


def _iterative_hint(solver: LinearSolver) -> str:
    """With iterative linear solves, what tells whether their error made the LCP fail (the
    compliance and the free displacements carry it), else ""."""
    if not solver.iterative:
        return ""
    return (f"; the linear solves are iterative (relative residual up to "
            f"{solver.worst_residual:.1e}): rerun with the default MUMPS LU (no -ksp_type, "
            "-pc_type) to tell whether their error is the cause")


def _fail(ctx: RunContext, model: Model, step: int, result: StepSolution,
          solver: LinearSolver) -> None:
    """Record the failed step in the summary and raise the one-line reason."""
    summary = ctx.summary
    summary["status"] = "failed"
    summary["failed_step"] = step + 1
    summary["timings"] = ctx.timer.reduced()
    done = f"steps 1..{step} are written in {ctx.out}" if step else "no step completed"
    held = "" if model.floating is None else (
        "; held only by contact: " + held_text(model.floating))
    if model.floating is not None and "zero-energy" in held:
        held += "; " + HOURGLASS_HINT
    head = ("no static equilibrium" if result.status in ("secondary ray", "unbalanced load")
            else "the contact problem could not be solved")
    reason = f"{head} at step {step + 1}: {result.message}{held}{_iterative_hint(solver)}; {done}"
    summary["error"] = reason
    if ctx.rank == 0:
        with writing():  # (a watchdog's stop waits for it)
            write_summary(ctx.out, summary)
    raise SolveError(reason)
