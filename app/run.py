"""The run driver: mesh -> discretisation -> assembly -> (contact) -> load steps -> output.

Every rank runs this; the mesh is built on rank 0 and broadcast; the stiffness is
distributed; the contact LCP is solved on rank 0 and its result broadcast.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from petsc4py import PETSc

from app.assembly.loads import (
    body_force_vector,
    constrained_dofs,
    load_vector,
    support_dofs,
)
from app.assembly.solve import (
    LinearSolver,
    SingularStiffnessError,
    apply_dirichlet,
    set_default_options,
)
from app.assembly.stiffness import assemble_stiffness, node_ownership
from app.condensation.compliance import (
    attach_schur,
    compliance_from_factor,
    compliance_solve,
    request_schur,
)
from app.config import Config
from app.contact.discretisation import contact_discretisation
from app.discretisation.bulk import (
    Discretisation,
    check_elements,
    element_fields,
    zero_energy_modes,
)
from app.discretisation.methods import bulk_method
from app.errors import InputError, SolveError
from app.interface.setup import ContactSetup, floating_modes, mismatch
from app.mesh.model import Mesh
from app.output.progress import step_line
from app.output.provenance import provenance
from app.output.reactions import ReactionProbe, support_owner, unique_names
from app.output.status import (
    RunGuard,
    arm_signals,
    check_finite,
    hold_signals,
    on_failure,
    release_signals,
    step_writing,
)
from app.output.summary import write_summary as write_summary_file
from app.output.xdmf import ResultWriter, restore_steps
from app.parallel import Timer, collective, from_numpy, to_numpy_all
from app.references import ContactProfile, RunFigures, reference


@dataclass
class RunOptions:
    """Command-line choices that override the config."""

    out: Path = Path("out")
    method: str | None = None
    sd: int | None = None
    mesh_scale: float = 1.0
    quiet: bool = False
    mesh_cache: Path | None = None
    progress_prefix: str = ""  # e.g. "level 2/5 CS-FEM-4SD" in a study
    overrides: list[str] = field(default_factory=list)  # the --set strings (provenance)
    refine: int = 0  # uniform splits of the (scaled) config mesh, see app/mesh/refine.py


def make_discretisation(cfg: Config, opts: RunOptions) -> Discretisation:
    """The bulk method and materials; the method and sd checked against the registry."""
    method = bulk_method(opts.method or cfg.method,
                         "--method" if opts.method else "analysis.method")
    sd = method.check_sd(opts.sd if opts.sd is not None else cfg.sd,
                         "--sd" if opts.sd is not None else "analysis.sd")
    return Discretisation(method.name, sd, cfg.plane, cfg.thickness, cfg.E, cfg.nu)


def build_scene_mesh(cfg: Config, opts: RunOptions) -> Mesh:
    from app.mesh.build import build_mesh
    from app.mesh.checks import check_scene

    mesh = build_mesh(cfg.scene, scale=opts.mesh_scale, cache_dir=opts.mesh_cache,
                      base_dir=cfg.path.parent)
    if opts.refine:
        from app.mesh.refine import refine_mesh, scene_arcs

        mesh = refine_mesh(mesh, opts.refine, scene_arcs(cfg.scene))
    check_elements(mesh)
    check_scene(mesh, cfg.interfaces)
    return mesh


@dataclass
class LoadCase:
    """One load or support with its history; u is its unit solution K^-1 b."""

    name: str
    history: np.ndarray
    rhs: np.ndarray  # (2n,) forces at factor 1
    prescribed: np.ndarray  # (2n,) prescribed displacement values at factor 1


def load_cases(mesh: Mesh, cfg: Config) -> list[LoadCase]:
    n2 = 2 * mesh.n_nodes
    cases = []
    names = unique_names([f"load:{ld.on}" for ld in cfg.loads]
                         + [f"support:{s.on}" for s in cfg.supports])
    names = dict(zip([id(x) for x in cfg.loads + cfg.supports], names, strict=True))
    for ld in cfg.loads:
        cases.append(LoadCase(names[id(ld)], ld.history, load_vector(mesh, cfg, ld),
                              np.zeros(n2)))
    bf = body_force_vector(mesh, cfg)
    if np.any(bf):
        cases.append(LoadCase("body_force", np.ones(cfg.n_steps), bf, np.zeros(n2)))
    for s in cfg.supports:
        dofs, vals = support_dofs(mesh, s, cfg.parameters)
        if np.any(vals):
            ud = np.zeros(n2)
            ud[dofs] = vals
            cases.append(LoadCase(names[id(s)], s.history, np.zeros(n2), ud))
    return cases


CONSISTENCY_TOL = 1e-9
"""Largest |G u - LCP kinematics| / max |u| accepted without a refinement re-solve."""
MAX_REFINEMENTS = 5
"""Consistency re-solves per step at most (each: one LCP solve and one back-substitution)."""


def write_summary(out: Path, summary: dict) -> None:
    """OUT/summary.json; later calls for the same run append (app/output/summary.py)."""
    write_summary_file(out / "summary.json", summary)


def run(cfg: Config, opts: RunOptions) -> dict:
    """Run a scene; returns the summary (also written to OUT/summary.json on rank 0).

    Every exit leaves OUT/summary.json with status completed, failed or interrupted
    (see app/output/status.py); a second run into the same OUT is refused.
    """
    set_default_options(cfg.petsc)
    summary = {"config": str(cfg.path), "n_steps": cfg.n_steps, "steps": [],
               "status": "running",
               "provenance": collective(provenance, cfg.raw, opts.overrides,
                                        PETSc.COMM_WORLD.getSize())}
    # inf and NaN from overflowing inputs are caught per step by check_finite
    with RunGuard(Path(opts.out), summary, write_summary, cfg.n_steps), \
            np.errstate(over="ignore", invalid="ignore"):
        return _run(cfg, opts, summary)


def _run(cfg: Config, opts: RunOptions, summary: dict) -> dict:
    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    rank, size = comm.getRank(), comm.getSize()
    timer = Timer(quiet=opts.quiet,
                  prefix=f"{opts.progress_prefix}: " if opts.progress_prefix else "")
    disc = make_discretisation(cfg, opts)
    for itf in cfg.interfaces:  # the contact discretisations, checked before any meshing
        contact_discretisation(itf.discretisation, f"interface '{itf.name}'")
    out = Path(opts.out)

    with timer.phase("mesh"):
        mesh = collective(build_scene_mesh, cfg, opts)
        arm_signals()  # gmsh.finalize() put back the default SIGTERM action
        _mesh_quality(mesh, summary, opts.quiet or rank != 0)
    n_dofs = 2 * mesh.n_nodes
    summary.update({
        "config": str(cfg.path),
        "method": disc.method,
        "sd": disc.sd if disc.bulk.sd_choices else None,
        "label": disc.label,
        "plane": disc.plane,
        "ranks": size,
        "n_nodes": mesh.n_nodes,
        "n_dofs": n_dofs,
        "n_elements": mesh.n_elements,
        "n_bodies": len(mesh.body_names),
        "bodies": mesh.body_names,
        "n_steps": cfg.n_steps,
        "steps": [],
        "status": "running",
    })
    for name in cfg.body_names:
        if name not in mesh.body_names:
            raise InputError(f"body '{name}' has no elements in the mesh")

    # Checks that need the mesh, before any expensive work.
    with timer.phase("setup"):
        cases = load_cases(mesh, cfg)
        fixed = constrained_dofs(mesh, cfg)
    contact = None
    if cfg.interfaces:
        with timer.phase("pair_search"):
            contact = ContactSetup.build(mesh, cfg)
        summary["n_pairs"] = contact.pairs.n_pairs
    with timer.phase("floating_modes"):  # with CS-FEM-1SD: the hourglass eigen-solve
        floating = floating_modes(mesh, cfg, fixed, contact, disc)
        pins = floating.pins if floating else np.zeros(0, dtype=np.int64)
        fixed_all = np.union1d(fixed, pins)
    with timer.phase("setup"):
        warnings = _prescribed_load_warnings(cases, fixed, rank)
        if warnings:
            summary["warnings"] = summary.get("warnings", []) + warnings

    with timer.phase("assembly"):
        k = assemble_stiffness(mesh, disc, comm)
    with timer.phase("boundary_conditions"):
        prescribed_rhs = []
        for case in cases:
            if np.any(case.prescribed):
                ud = from_numpy(k, case.prescribed)
                kud = k.createVecLeft()
                k.mult(ud, kud)
                prescribed_rhs.append(to_numpy_all(kud))
            else:
                prescribed_rhs.append(None)
        probe = ReactionProbe(k, fixed)
        apply_dirichlet(k, fixed_all)

    with timer.phase("factorization"):
        solver = LinearSolver(k)
        route = contact.compliance_route(solver) if contact is not None else None
        schur_dofs = request_schur(solver, contact.g, fixed_all) if route == "schur" else None
        try:
            solver.factor()
        except SingularStiffnessError as exc:
            raise SolveError(_singular_message(disc, mesh, str(exc), fixed_all)) from None
        if schur_dofs is not None:  # the one factorization serves compliance and solves
            attach_schur(solver, k, schur_dofs)

    with timer.phase("solve"):
        unit, lifted = [], []
        for case, kud in zip(cases, prescribed_rhs, strict=True):
            b = case.rhs.copy()
            if kud is not None:
                b -= kud
            lifted.append(np.where(np.isin(np.arange(b.size), fixed), 0.0, b))
            b[fixed_all] = case.prescribed[fixed_all]
            try:
                x = solver.solve(from_numpy(k, b))
            except SingularStiffnessError as exc:
                raise SolveError(_singular_message(disc, mesh, str(exc), fixed_all)) from None
            unit.append(to_numpy_all(x))

    stepper = None
    if contact is not None:
        with timer.phase("compliance"):
            if route == "schur":
                c_mat = compliance_from_factor(solver, contact.g, fixed_all)
            else:
                c_mat = compliance_solve(solver, k, contact.g, fixed_all, to_numpy_all)
        summary["compliance_route"] = route
        with timer.phase("lcp"):
            stepper = contact.stepper(c_mat, cases, unit, lifted, floating) \
                if rank == 0 else None

    with timer.phase("output"):
        own = node_ownership(mesh.n_nodes, size)
        my_elements = np.flatnonzero(
            (mesh.quads[:, 0] >= own[rank]) & (mesh.quads[:, 0] < own[rank + 1])
        )
        writer = ResultWriter(out, mesh.points, mesh.quads, mesh.body) if rank == 0 else None
        if writer is not None:  # files and summary.json agree after any failure
            on_failure(lambda: restore_steps(writer, len(summary["steps"])))
    last_contact = None
    with timer.phase("setup"):
        reactions = _reaction_setup(mesh, cfg, cases, probe)
    for step in range(cfg.n_steps):
        t_step = time.perf_counter()
        with timer.phase("recovery"):  # superposition of the unit solutions
            u = np.zeros(n_dofs)
            for case, uc in zip(cases, unit, strict=True):
                u += case.history[step] * uc
        step_info = {"step": step + 1,
                     "load_factor": {c.name: float(c.history[step]) for c in cases}}
        contact_data = None
        if contact is not None:
            with timer.phase("lcp"):
                result = stepper.step(step, cases) if rank == 0 else None
                result = mpi.bcast(result, root=0)
            if result["status"] != "solved":
                summary["status"] = "failed"
                summary["failed_step"] = step + 1
                summary["timings"] = timer.reduced()
                done = f"steps 1..{step} are written in {out}" if step else \
                    "no step completed"
                held = "" if floating is None else (
                    "; held only by contact: " + ", ".join(floating.names))
                head = ("no static equilibrium"
                        if result["status"] in ("secondary ray", "unbalanced load")
                        else "the contact problem could not be solved")
                reason = f"{head} at step {step + 1}: {result['message']}{held}; {done}"
                summary["error"] = reason
                if rank == 0:
                    write_summary(out, summary)
                raise SolveError(reason)
            u_free = u.copy()
            correction = np.zeros(2 * contact.pairs.n_pairs) if rank == 0 else None
            refinements, previous = 0, np.inf
            while True:
                with timer.phase("recovery"):
                    u = u_free + contact.displacement(result["lam"], solver, k, fixed_all,
                                                      to_numpy_all)
                    if floating is not None and floating.r.shape[1]:
                        u += floating.r @ result["alpha"]
                    rel = again = None
                    if rank == 0:
                        miss = mismatch(contact.g, u, result)
                        scale = max(np.abs(u).max(initial=0.0), 1e-300)
                        rel = float(np.abs(miss).max(initial=0.0) / scale)
                        again = (rel > CONSISTENCY_TOL and refinements < MAX_REFINEMENTS
                                 and rel < 0.5 * previous)
                    again, rel = mpi.bcast((again, rel), root=0)
                if not again:
                    break
                previous = rel
                with timer.phase("lcp"):
                    retry = None
                    if rank == 0:
                        correction += miss
                        retry = stepper.refine(step, cases, correction)
                    retry = mpi.bcast(retry, root=0)
                if retry is None:
                    break
                result = retry
                refinements += 1
            result["info"]["consistency_refinements"] = refinements
            result["info"]["lcp_displacement_mismatch"] = rel
            step_info.update(result["info"])
        with timer.phase("output"):
            if contact is not None and rank == 0:
                contact_data = contact.output_data(result, u, mesh)
                step_info["kkt"] = contact_data.pop("_kkt")
                last_contact = contact_data
                _add_interface_forces(step_info, contact_data, cfg)
            step_info.update(reactions(step, u, None if contact is None else
                                       contact.g.T @ result["lam"]))
            fields = element_fields(mesh, disc, u, my_elements)
            gathered = mpi.gather((my_elements, fields), root=0)
            energy_by_body = np.bincount(mesh.body[my_elements], weights=fields["energy"],
                                         minlength=len(mesh.body_names))
            energy_by_body = mpi.allreduce(energy_by_body)
            energy_total = float(energy_by_body.sum())
            check_finite(step + 1, cfg.n_steps, u, energy_total)
            hold_signals()  # the step's files and summary.json are written together
            step_writing(True)
            if rank == 0:
                cell = _assemble_cell_fields(mesh, gathered)
                disp = np.zeros((mesh.n_nodes, 3))
                disp[:, :2] = u.reshape(-1, 2)
                writer.write_step(step + 1, float(step + 1), {"displacement": disp}, cell,
                                  contact_data, load_factors=step_info["load_factor"])
            step_info["step_seconds"] = time.perf_counter() - t_step
            step_info["elapsed_seconds"] = time.perf_counter() - timer.start
            step_info["strain_energy"] = energy_total
            step_info["strain_energy_by_body"] = dict(
                zip(mesh.body_names, map(float, energy_by_body), strict=True))
            summary["steps"].append(step_info)
            summary["strain_energy"] = energy_total
            summary["strain_energy_by_body"] = step_info["strain_energy_by_body"]
            summary["timings"] = timer.reduced()
            if rank == 0:
                write_summary(out, summary)
                if not opts.quiet:
                    print(step_line(step_info, cfg.n_steps, timer.prefix), file=sys.stderr,
                          flush=True)
        step_writing(False)
        release_signals()

    with timer.phase("reference"):
        summary["point_values"] = _point_values(mesh, u)
        ref = collective(reference_errors, cfg, disc, summary, mesh, contact, last_contact)
        if ref:
            summary["reference"] = ref
    summary["status"] = "completed"
    timings = timer.reduced()
    timings["total"] = time.perf_counter() - timer.start
    summary["timings"] = {k: timings.get(k, 0.0) for k in
                          ("mesh", "assembly", "factorization", "solve", "output")} | timings
    summary["assembly_rate_elements_per_s"] = mesh.n_elements / max(timings["assembly"], 1e-12)
    summary["peak_memory_mb"] = timer.memory()
    if rank == 0:
        write_summary(out, summary)
    return summary


def _mesh_quality(mesh: Mesh, summary: dict, quiet: bool) -> None:
    """Degenerate or non-convex elements are an error; else one line and summary.json."""
    from app.mesh.quality import mesh_quality, quality_line

    summary["mesh_quality"] = mesh_quality(mesh)
    if not quiet:
        print(quality_line(summary["mesh_quality"]), file=sys.stderr, flush=True)


def _prescribed_load_warnings(cases: list[LoadCase], fixed: np.ndarray, rank: int) -> list[str]:
    """Loads acting on prescribed DOFs go straight into the support reaction: say so."""
    out = []
    for case in cases:
        on_fixed = case.rhs[fixed]
        if np.any(on_fixed):
            out.append(f"{case.name}: {np.count_nonzero(on_fixed)} of its nodal forces act on "
                       f"prescribed DOFs (sum {np.abs(on_fixed).sum():.4g}) and are taken by "
                       "the supports, not by the bodies; see steps[k].reactions")
    if rank == 0:
        for w in out:
            print(f"warning: {w}", file=sys.stderr)
    return out


def _reaction_setup(mesh: Mesh, cfg: Config, cases: list[LoadCase], probe: ReactionProbe):
    """A function (step, u, contact nodal forces) -> {"reactions", "balance"} for steps[k]."""
    from app.output.reactions import body_extents, step_reactions

    names = unique_names([f"support:{s.on}" for s in cfg.supports])
    owner = support_owner([support_dofs(mesh, s, cfg.parameters)[0] for s in cfg.supports],
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


def _add_interface_forces(step_info: dict, contact_data: dict, cfg: Config) -> None:
    """Resultant force vectors (global axes) into steps[k].interfaces.<name>.force."""
    from app.output.reactions import interface_resultants

    res = interface_resultants(contact_data, [i.name for i in cfg.interfaces])
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
                         point_values=summary["point_values"], contact=profile)
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
        mu=cfg.interfaces[0].mu, E_star=float(e_star), interface=cfg.interfaces[0].name)


def _assemble_cell_fields(mesh: Mesh, gathered) -> dict[str, np.ndarray]:
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


def _point_values(mesh: Mesh, u: np.ndarray) -> dict:
    """Displacement at the named point groups (first node of each)."""
    out = {}
    for name, nodes in mesh.point_groups.items():
        n = int(np.atleast_1d(nodes)[0])
        out[name] = {"x": float(mesh.points[n, 0]), "y": float(mesh.points[n, 1]),
                     "ux": float(u[2 * n]), "uy": float(u[2 * n + 1])}
    return out


def _singular_message(disc: Discretisation, mesh: Mesh, detail: str,
                      fixed: np.ndarray | None = None) -> str:
    """Name the bodies whose stiffness keeps zero-energy modes under their supports."""
    names = []
    if fixed is not None:
        for b in range(len(mesh.body_names)):
            if np.sum(mesh.body == b) <= 20000:
                if zero_energy_modes(mesh, disc, b, fixed).shape[1] > 0:
                    names.append(f"'{mesh.body_names[b]}'")
    where = f" in body {', '.join(names)}" if names else ""
    if disc.hourglass:
        return (f"{detail}: {disc.label} has hourglass (zero-energy) modes{where} that the "
                "supports do not suppress; use --sd 2 or more (hourglass-free smoothing) or "
                "--method fem-q4")
    return f"{detail}: check that every body is held by supports{where}"
