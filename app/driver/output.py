"""Phase 5's output and phase 6: the writer, each step's fields, energies, reactions,
contact arrays, files and summary.json, and at the end the errors against the closed form."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from app.assembly.loads import LoadCase, all_support_dofs, unique_names
from app.assembly.solve import LinearSolver
from app.assembly.stiffness import node_ownership
from app.config import Config
from app.discretisation.bulk import Discretisation, element_fields, element_operators
from app.driver.contact import ContactStep, solve_rel
from app.driver.context import RunContext, write_summary
from app.driver.linear import LinearSystem
from app.driver.model import Model
from app.driver.rank0_io import on_rank0
from app.driver.rank0_solve import on_rank0_solve
from app.mesh.model import Mesh
from app.output.accuracy_warning import ACCURACY_WARN, accuracy_warning, interface_contrasts
from app.output.balance_warning import balance_warning
from app.output.contact import contact_arrays, kkt_pairs_check
from app.output.kkt_warning import kkt_warning
from app.output.pair_law import kkt_pairs_warning
from app.output.progress import step_line
from app.output.reactions import ReactionProbe, support_owner
from app.output.rigid_motion import rigid_motion
from app.output.status import (
    check_finite,
    hold_signals,
    on_failure,
    release_signals,
    step_writing,
    writing,
)
from app.output.xdmf import ResultWriter, restore_steps
from app.parallel import collective, to_numpy_all
from app.references import ContactProfile, RunFigures, reference


@dataclass
class StepOutput:
    """Per-run output state: this rank's elements (owned by their first node), the writer
    (rank 0), the reactions function, the last step's contact arrays (rank 0) and, in runs
    of several steps, the strain matrices of my_elements (`element_operators`, formed at
    the first step); solver: the run's linear solver (its accuracy, for the warnings)."""

    my_elements: np.ndarray
    writer: ResultWriter | None
    reactions: Callable[[int, np.ndarray, np.ndarray | None], dict]
    last_contact: dict | None = None
    operators: list | None = None
    solver: LinearSolver | None = None


def open_output(ctx: RunContext, model: Model, system: LinearSystem) -> StepOutput:
    """Phases output (mesh.h5, the writer) and setup (the reactions of every support)."""
    mesh = model.mesh
    with ctx.phase("output"):
        own = node_ownership(mesh.n_nodes, ctx.size)
        first = mesh.quads[:, 0]
        my_elements = np.flatnonzero((first >= own[ctx.rank]) & (first < own[ctx.rank + 1]))
        with writing():  # (mesh.h5: a watchdog's stop waits for it)
            writer = on_rank0(ResultWriter, ctx.out, mesh.points, mesh.quads, mesh.body)
        if writer is not None:  # files and summary.json agree after any failure
            on_failure(lambda: restore_steps(writer, len(ctx.summary["steps"])))
    with ctx.phase("setup"):
        reactions = _reaction_setup(mesh, ctx.cfg, model.cases, system.probe)
    return StepOutput(my_elements, writer, reactions, solver=system.solver)


def superpose(ctx: RunContext, model: Model, unit: list[np.ndarray], step: int) -> np.ndarray:
    """Phase recovery: the displacement of the load cases at step `step` without contact."""
    with ctx.phase("recovery"):
        u = np.zeros(model.n_dofs)
        for case, uc in zip(model.cases, unit, strict=True):
            u += case.history[step] * uc
    return u


def write_step(ctx: RunContext, model: Model, output: StepOutput, step: int, u: np.ndarray,
               solved: ContactStep | None, started: float) -> None:
    """Phase output of step `step`: fields, energies, reactions, files, summary.json."""
    mesh, cfg, mpi = model.mesh, ctx.cfg, ctx.mpi
    info = {"step": step + 1,
            "load_factor": {c.name: float(c.history[step]) for c in model.cases}}
    contact_data = None
    with ctx.phase("output"):
        if solved is not None:
            info.update(solved.result.info)
            contact_data = on_rank0_solve(_contact_output, ctx, model, output, solved, u, info)
        info.update(output.reactions(step, u, None if solved is None else
                                     model.contact.g.T @ solved.result.lam))
        unbalanced = balance_warning(info["balance"], info["step"],
                                     0.0 if output.solver is None else solve_rel(output.solver))
        if unbalanced is not None:
            ctx.warn(unbalanced, ("balance",))
        if model.floating is not None:  # the floating bodies' motion (rigid_modes is not)
            info["rigid_motion"] = rigid_motion(mesh.points, mesh.node_body(), mesh.body_names,
                                                list(dict.fromkeys(model.floating.bodies)), u)
        if output.operators is None and cfg.n_steps > 1:
            output.operators = element_operators(mesh, model.disc, output.my_elements)
        fields = element_fields(mesh, model.disc, u, output.my_elements,
                                operators=output.operators)
        gathered = mpi.gather((output.my_elements, fields), root=0)
        by_body = mpi.allreduce(np.bincount(mesh.body[output.my_elements],
                                            weights=fields["energy"],
                                            minlength=len(mesh.body_names)))
        energy = float(by_body.sum())
        check_finite(step + 1, cfg.n_steps, u, energy)
        # PETSc objects that Python dropped wait in petsc4py's garbage until a collective
        # clean-up: without it, each step's solve vectors stayed (0.5 MB a step at 38,580
        # DOFs, 2.2 MB at 153,060: 0.67 GB over 300 steps)
        PETSc.garbage_cleanup()
        hold_signals()  # the step's files and summary.json are written together
        step_writing(True)
        on_rank0(_write_step, output.writer, step, mesh, u, gathered, contact_data, info)
        _record_step(ctx, info, energy, dict(zip(mesh.body_names, map(float, by_body),
                                                  strict=True)), started)
    step_writing(False)
    release_signals()


def _contact_output(ctx: RunContext, model: Model, output: StepOutput, solved: ContactStep,
                    u: np.ndarray, info: dict) -> dict:
    """Rank 0: the step's per-pair contact arrays, its KKT check (info) and interface
    forces; the last step's arrays kept in `output`."""
    contact_data, info["kkt"] = contact_arrays(model.contact, solved.result, u,
                                               ctx.cfg.thickness)
    law = kkt_warning(info["kkt"], info["step"])
    if law is not None:
        ctx.warn(law, ("kkt",))
    info["kkt_pairs"] = kkt_pairs_check(model.contact, solved.result, u,
                                        model.mesh.node_body(),
                                        [itf.name for itf in ctx.cfg.interfaces],
                                        solved.solve_rel)
    law = kkt_pairs_warning(info["kkt_pairs"], info["step"])
    if law is not None:
        ctx.warn(law, ("kkt_pairs",))
    accuracy = info.get("lcp_accuracy", 0.0)
    if not accuracy <= ACCURACY_WARN:
        ctx.warn(accuracy_warning(accuracy, info["step"],
                                  interface_contrasts(model.mesh, ctx.cfg)), ("lcp_accuracy",))
    output.last_contact = contact_data
    _add_interface_forces(info, contact_data, ctx.cfg, model.contact.described)
    return contact_data


def _write_step(writer: ResultWriter, step: int, mesh, u: np.ndarray, gathered,
                contact_data, info: dict) -> None:
    """Rank 0: the step's HDF5 file and XDMF entries."""
    disp = np.zeros((mesh.n_nodes, 3))
    disp[:, :2] = u.reshape(-1, 2)
    writer.write_step(step + 1, float(step + 1), {"displacement": disp},
                      _cell_fields(mesh, gathered), contact_data,
                      load_factors=info["load_factor"])


def _record_step(ctx: RunContext, info: dict, energy: float, by_body: dict,
                 started: float) -> None:
    """The step's entry in summary.json (written), and its progress line."""
    info["step_seconds"] = time.perf_counter() - started
    info["elapsed_seconds"] = time.perf_counter() - ctx.timer.start
    info["strain_energy"] = energy
    info["strain_energy_by_body"] = by_body
    summary = ctx.summary
    summary["steps"].append(info)
    summary["strain_energy"] = energy
    summary["strain_energy_by_body"] = by_body
    summary["timings"] = ctx.timer.reduced()
    on_rank0(write_summary, ctx.out, summary)
    if ctx.rank == 0:
        if not ctx.opts.quiet:
            print(step_line(info, ctx.cfg.n_steps, ctx.timer.prefix), file=sys.stderr,
                  flush=True)


def finish(ctx: RunContext, model: Model, output: StepOutput, u: np.ndarray) -> dict:
    """Phase reference (point values, closed-form errors); the completed summary."""
    summary, timer = ctx.summary, ctx.timer
    with ctx.phase("reference"):
        summary["point_values"] = point_values(model.mesh, u)
        ref = collective(reference_errors, ctx.cfg, model.disc, summary, model.mesh,
                         model.contact, output.last_contact)
        if ref:
            summary["reference"] = ref
    summary["status"] = "completed"
    timings = timer.reduced()
    timings["total"] = timer.total()
    summary["timings"] = {k: timings.get(k, 0.0) for k in
                          ("mesh", "assembly", "factorization", "solve", "output")} | timings
    summary["assembly_rate_elements_per_s"] = (model.mesh.n_elements
                                               / max(timings["assembly"], 1e-12))
    summary["peak_memory_mb"] = timer.memory()
    with writing():  # (a watchdog's stop waits for it)
        on_rank0(write_summary, ctx.out, summary)
    return summary


def _reaction_setup(mesh: Mesh, cfg: Config, cases: list[LoadCase], probe: ReactionProbe):
    """A function (step, u, contact nodal forces) -> {"reactions", "balance"} for steps[k]."""
    from app.output.reactions import body_extents, step_reactions

    names = unique_names([f"support:{s.on}" for s in cfg.supports])
    owner = support_owner([d for d, _ in all_support_dofs(mesh, cfg.supports, cfg.parameters)],
                          2 * mesh.n_nodes)
    node_body = mesh.node_body()
    extents = body_extents(mesh.points, node_body, len(mesh.body_names))
    largest = [0.0]  # the largest force scale of the steps so far (balance floor)

    def at_step(step: int, u: np.ndarray, contact_force: np.ndarray | None) -> dict:
        applied = np.zeros_like(u)
        body = np.zeros_like(u)
        for c in cases:
            target = body if c.name == "body_force" else applied
            target += c.history[step] * c.rhs
        r = step_reactions(probe, u, applied, body, contact_force, owner, names, mesh.points,
                           node_body, mesh.body_names, to_numpy_all, extents, largest[0])
        largest[0] = max(largest[0], r["balance"]["force_scale"])
        return {"reactions": r["supports"], "balance": r["balance"]}

    return at_step


def _add_interface_forces(step_info: dict, contact_data: dict, cfg: Config,
                          described: dict | None = None) -> None:
    """Resultant force vectors (global axes) into steps[k].interfaces.<name>.force, on
    the configured slave side also where the pairs are on the master (`described`)."""
    from app.output.reactions import interface_resultants

    swapped = {i.name for i in cfg.interfaces
               if (described or {}).get(i.name, {}).get("pairs_on", i.slave) != i.slave}
    res = interface_resultants(contact_data, [i.name for i in cfg.interfaces], swapped)
    for name, val in res.items():
        step_info.setdefault("interfaces", {}).setdefault(name, {}).update(val)


def reference_errors(cfg: Config, disc: Discretisation, summary: dict, mesh: Mesh,
                     contact=None, last_contact: dict | None = None) -> dict | None:
    """Errors against the closed form named in the config's [reference] table (rank 0)."""
    if cfg.reference is None:
        return None
    profile = None
    if contact is not None and last_contact is not None:
        profile = _contact_profile(cfg, disc, mesh, contact, last_contact)
    figures = RunFigures(E=float(disc.E[0]), nu=float(disc.nu[0]), plane=disc.plane,
                         thickness=disc.thickness, strain_energy=summary["strain_energy"],
                         point_values=summary["point_values"], contact=profile,
                         steps=summary.get("steps", []))
    return reference(cfg.reference["type"]).compare(cfg.reference, figures)


def _contact_profile(cfg: Config, disc: Discretisation, mesh: Mesh, contact,
                     data: dict) -> ContactProfile:
    """The first interface's pairs at the last step, with the bodies' effective modulus."""
    from app.interface.steps import STICK

    nb = mesh.node_body()
    bodies = (nb[contact.pairs.slave[0]], nb[contact.pairs.master[0, 0]])
    if disc.plane == "stress":
        e_star = 1.0 / sum(1.0 / disc.E[b] for b in bodies)
    else:
        e_star = 1.0 / sum((1 - disc.nu[b] ** 2) / disc.E[b] for b in bodies)
    sel = data["interface"] == 0
    return ContactProfile(
        x=data["x"][sel], p=data["p"][sel], q=data["q"][sel], length=data["length"][sel],
        p_force=data["p_force"][sel], q_force=data["q_force"][sel],
        stick=(data["state"][sel] == STICK) & (data["p"][sel] > 0),
        mu=cfg.interfaces[0].mu, E_star=float(e_star), interface=cfg.interfaces[0].name,
        y=data["y"][sel], tangent=data["tangent"][sel])


def _cell_fields(mesh: Mesh, gathered) -> dict[str, np.ndarray]:
    """The element fields of every rank's elements, on rank 0."""
    ne = mesh.n_elements
    stress = np.zeros((ne, 4))
    vm = np.zeros(ne)
    sed = np.zeros(ne)
    for el, f in gathered:
        stress[el] = f["stress"]
        vm[el] = f["von_mises"]
        sed[el] = f["energy_density"]
    return {"stress": stress, "von_mises": vm, "strain_energy_density": sed,
            "body_id": mesh.body.astype(np.int64)}


def point_values(mesh: Mesh, u: np.ndarray) -> dict:
    """Displacement at the named point groups (first node of each)."""
    out = {}
    for name, nodes in mesh.point_groups.items():
        n = int(np.atleast_1d(nodes)[0])
        out[name] = {"x": float(mesh.points[n, 0]), "y": float(mesh.points[n, 1]),
                     "ux": float(u[2 * n]), "uy": float(u[2 * n + 1])}
    return out
