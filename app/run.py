"""The run driver: mesh -> discretisation -> assembly -> (contact) -> load steps -> output.

Every rank runs this; the mesh is built on rank 0 and broadcast; the stiffness is
distributed; the contact LCP is solved on rank 0 and its result broadcast.
"""

from __future__ import annotations

import json
import resource
import sys
import time
from contextlib import contextmanager
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
from app.assembly.solve import LinearSolver, apply_dirichlet, set_default_options
from app.assembly.stiffness import assemble_stiffness, node_ownership
from app.condensation.compliance import compliance_schur, compliance_solve
from app.config import Config
from app.discretisation.bulk import (
    Discretisation,
    check_elements,
    element_fields,
    zero_energy_modes,
)
from app.errors import InputError, SolveError
from app.interface.setup import ContactSetup, floating_modes, mismatch
from app.mesh.model import Mesh
from app.output.xdmf import ResultWriter, atomic_write_text


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


@dataclass
class Timer:
    """Wall-clock seconds per phase (max over ranks is reported) and PETSc log stages."""

    seconds: dict[str, float] = field(default_factory=dict)
    peak_mb: dict[str, float] = field(default_factory=dict)
    quiet: bool = False
    prefix: str = ""
    start: float = field(default_factory=time.perf_counter)
    _stages: dict = field(default_factory=dict)

    @contextmanager
    def phase(self, name: str):
        comm = PETSc.COMM_WORLD
        if name not in self._stages:
            self._stages[name] = PETSc.Log.Stage(name)
        stage = self._stages[name]
        stage.push()
        comm.barrier()  # a phase's time includes waiting for the slowest rank
        t0 = time.perf_counter()
        try:
            yield
        finally:
            comm.barrier()
            stage.pop()
            dt = time.perf_counter() - t0
            self.seconds[name] = self.seconds.get(name, 0.0) + dt
            self.peak_mb[name] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
            if not self.quiet and comm.getRank() == 0:
                el = time.perf_counter() - self.start
                print(f"[{el:8.2f} s] {self.prefix}{name:<14s} {dt:8.3f} s", file=sys.stderr,
                      flush=True)

    def reduced(self) -> dict[str, float]:
        comm = PETSc.COMM_WORLD.tompi4py()
        out = {}
        for k in sorted(self.seconds):
            out[k] = comm.allreduce(self.seconds[k], op=_mpi_max())
        return out

    def memory(self) -> dict[str, float]:
        """Peak resident memory (MB) of the whole job, summed over ranks, at the end of
        each phase's first completion order (a running maximum)."""
        comm = PETSc.COMM_WORLD.tompi4py()
        return {k: round(comm.allreduce(v), 1) for k, v in sorted(self.peak_mb.items())}


def _mpi_max():
    from mpi4py import MPI

    return MPI.MAX


def collective(fn, *args, **kwargs):
    """Run fn on rank 0 and broadcast its result, or its InputError/SolveError, to all."""
    comm = PETSc.COMM_WORLD.tompi4py()
    result, error = None, None
    if comm.rank == 0:
        try:
            result = fn(*args, **kwargs)
        except (InputError, SolveError) as exc:
            error = exc
    result, error = comm.bcast((result, error), root=0)
    if error is not None:
        raise error
    return result


def to_numpy_all(vec: PETSc.Vec) -> np.ndarray:
    """A copy of a distributed vector on every rank."""
    scatter, seq = PETSc.Scatter.toAll(vec)
    scatter.scatter(vec, seq, addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    out = seq.getArray().copy()
    scatter.destroy()
    seq.destroy()
    return out


def from_numpy(template: PETSc.Mat, values: np.ndarray) -> PETSc.Vec:
    """A distributed vector with this rank's slice of a global numpy array."""
    v = template.createVecLeft()
    r0, r1 = v.getOwnershipRange()
    v.setArray(values[r0:r1])
    return v


def make_discretisation(cfg: Config, opts: RunOptions) -> Discretisation:
    method = opts.method or cfg.method
    sd = opts.sd if opts.sd is not None else cfg.sd
    if method not in ("cs-fem", "fem-q4"):
        raise InputError(f"--method {method}: use cs-fem or fem-q4")
    from app.discretisation.elements import SMOOTHING_DOMAINS

    if method == "cs-fem" and sd not in SMOOTHING_DOMAINS:
        raise InputError(f"--sd {sd}: choose one of {list(SMOOTHING_DOMAINS)}")
    return Discretisation(method, sd, cfg.plane, cfg.thickness, cfg.E, cfg.nu)


def build_scene_mesh(cfg: Config, opts: RunOptions) -> Mesh:
    from app.mesh.build import build_mesh

    mesh = build_mesh(cfg.raw, scale=opts.mesh_scale, cache_dir=opts.mesh_cache,
                      base_dir=cfg.path.parent)
    check_elements(mesh)
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
    for ld in cfg.loads:
        cases.append(LoadCase(f"load:{ld.on}", ld.history, load_vector(mesh, cfg, ld),
                              np.zeros(n2)))
    bf = body_force_vector(mesh, cfg)
    if np.any(bf):
        cases.append(LoadCase("body_force", np.ones(cfg.n_steps), bf, np.zeros(n2)))
    for s in cfg.supports:
        dofs, vals = support_dofs(mesh, s, cfg.parameters)
        if np.any(vals):
            ud = np.zeros(n2)
            ud[dofs] = vals
            cases.append(LoadCase(f"support:{s.on}", s.history, np.zeros(n2), ud))
    return cases


CONSISTENCY_TOL = 1e-9
"""Largest |G u - LCP kinematics| / max |u| accepted without a refinement re-solve."""
MAX_REFINEMENTS = 5
"""Consistency re-solves per step at most (each: one LCP solve and one back-substitution)."""


def write_summary(out: Path, summary: dict) -> None:
    atomic_write_text(out / "summary.json", json.dumps(summary, indent=2) + "\n")


def run(cfg: Config, opts: RunOptions) -> dict:
    """Run a scene; returns the summary (also written to OUT/summary.json on rank 0)."""
    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    rank, size = comm.getRank(), comm.getSize()
    timer = Timer(quiet=opts.quiet,
                  prefix=f"{opts.progress_prefix}: " if opts.progress_prefix else "")
    set_default_options(cfg.petsc)
    disc = make_discretisation(cfg, opts)
    out = Path(opts.out)
    if rank == 0:
        out.mkdir(parents=True, exist_ok=True)

    with timer.phase("mesh"):
        mesh = collective(build_scene_mesh, cfg, opts)
    n_dofs = 2 * mesh.n_nodes
    summary = {
        "config": str(cfg.path),
        "method": disc.method,
        "sd": disc.sd if disc.method == "cs-fem" else None,
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
    }
    for name in cfg.body_names:
        if name not in mesh.body_names:
            raise InputError(f"body '{name}' has no elements in the mesh")

    # Checks that need the mesh, before any expensive work.
    cases = load_cases(mesh, cfg)
    fixed = constrained_dofs(mesh, cfg)
    contact = None
    if cfg.interfaces:
        with timer.phase("pair_search"):
            contact = ContactSetup.build(mesh, cfg)
        summary["n_pairs"] = contact.pairs.n_pairs
    floating = floating_modes(mesh, cfg, fixed, contact, disc)
    pins = floating.pins if floating else np.zeros(0, dtype=np.int64)
    fixed_all = np.union1d(fixed, pins)

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
        apply_dirichlet(k, fixed_all)

    solver = LinearSolver(k)
    with timer.phase("factorization"):
        try:
            solver.factor()
        except SolveError as exc:
            raise SolveError(_singular_message(disc, mesh, str(exc), fixed_all)) from None

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
            except SolveError as exc:
                raise SolveError(_singular_message(disc, mesh, str(exc), fixed_all)) from None
            unit.append(to_numpy_all(x))

    stepper = None
    if contact is not None:
        with timer.phase("compliance"):
            route = contact.compliance_route(solver)
            if route == "schur":
                c_mat = compliance_schur(k, contact.g, fixed_all)
            else:
                c_mat = compliance_solve(solver, k, contact.g, fixed_all, to_numpy_all)
        summary["compliance_route"] = route
        with timer.phase("lcp"):
            stepper = contact.stepper(c_mat, cases, unit, lifted, floating) \
                if rank == 0 else None

    own = node_ownership(mesh.n_nodes, size)
    my_elements = np.flatnonzero(
        (mesh.quads[:, 0] >= own[rank]) & (mesh.quads[:, 0] < own[rank + 1])
    )
    writer = ResultWriter(out, mesh.points, mesh.quads, mesh.body) if rank == 0 else None
    last_contact = None
    for step in range(cfg.n_steps):
        t_step = time.perf_counter()
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
                reason = (f"no static equilibrium at step {step + 1}: Lemke ended on a "
                          f"{result['status']} ({result['message']}{held}); {done}")
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
            if rank == 0:
                contact_data = contact.output_data(result, u, mesh)
                step_info["kkt"] = contact_data.pop("_kkt")
                last_contact = contact_data
        with timer.phase("output"):
            fields = element_fields(mesh, disc, u, my_elements)
            gathered = mpi.gather((my_elements, fields), root=0)
            energy_by_body = np.bincount(mesh.body[my_elements], weights=fields["energy"],
                                         minlength=len(mesh.body_names))
            energy_by_body = mpi.allreduce(energy_by_body)
            energy_total = float(energy_by_body.sum())
            if rank == 0:
                cell = _assemble_cell_fields(mesh, gathered)
                disp = np.zeros((mesh.n_nodes, 3))
                disp[:, :2] = u.reshape(-1, 2)
                writer.write_step(step + 1, float(step + 1), {"displacement": disp}, cell,
                                  contact_data)
        step_info["step_seconds"] = time.perf_counter() - t_step
        step_info["strain_energy"] = energy_total
        step_info["strain_energy_by_body"] = dict(
            zip(mesh.body_names, map(float, energy_by_body), strict=True))
        summary["steps"].append(step_info)
        summary["strain_energy"] = energy_total
        summary["strain_energy_by_body"] = step_info["strain_energy_by_body"]
        summary["timings"] = timer.reduced()
        if rank == 0:
            write_summary(out, summary)

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


def reference_errors(cfg: Config, disc: Discretisation, summary: dict, mesh: Mesh,
                     contact=None, last_contact: dict | None = None) -> dict | None:
    """Errors against the closed form named in the config's [reference] table (rank 0)."""
    ref = cfg.raw.get("reference")
    if not isinstance(ref, dict):
        return None
    kind = ref.get("type")
    if kind in ("hertz", "cattaneo"):
        from app.closed_form import cattaneo_errors, hertz_errors
        from app.interface.steps import STICK

        if contact is None or last_contact is None:
            raise InputError(f"[reference] type '{kind}' needs an [[interface]]")
        try:
            radius = float(ref["radius"])
            x0 = float(ref.get("center_x", 0.0))
        except (KeyError, TypeError, ValueError):
            raise InputError(f"[reference] type '{kind}' needs radius (and center_x)") from None
        nb = mesh.node_body()
        b1 = nb[contact.pairs.slave[0]]
        b2 = nb[contact.pairs.master[0, 0]]
        e_star = 1.0 / sum((1 - disc.nu[b] ** 2) / disc.E[b] for b in (b1, b2))
        if disc.plane == "stress":
            e_star = 1.0 / sum(1.0 / disc.E[b] for b in (b1, b2))
        c = last_contact
        sel = c["interface"] == 0
        p_force = c["p_force"][sel]
        total = float(p_force.sum())
        out = {"type": kind, "interface": cfg.interfaces[0].name}
        out |= {"hertz": hertz_errors(c["x"][sel], c["p"][sel], c["length"][sel], P=total,
                                      R=radius, E_star=e_star, x0=x0,
                                      thickness=disc.thickness)}
        if kind == "cattaneo" and not cfg.interfaces[0].mu * total > 0:
            out["cattaneo"] = {"skipped": "no Cattaneo-Mindlin reference without friction "
                                          "(mu = 0) or contact force"}
        elif kind == "cattaneo":
            stick = (c["state"][sel] == STICK) & (c["p"][sel] > 0)
            out["cattaneo"] = cattaneo_errors(
                c["x"][sel], c["p"][sel], c["q"][sel], c["length"][sel], stick, P=total,
                Q=float(c["q_force"][sel].sum()), mu=cfg.interfaces[0].mu, R=radius,
                E_star=e_star, x0=x0, thickness=disc.thickness)
        return out
    if kind == "timoshenko":
        from app.closed_form import timoshenko_cantilever

        try:
            P, L, D = (float(ref[k]) for k in ("P", "L", "D"))
            point = summary["point_values"][ref.get("point", "tip")]
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"[reference] type 'timoshenko' needs P, L, D and a point "
                             f"group: {exc}") from None
        exact = timoshenko_cantilever(L, 0.0, P=P, L=L, D=D, E=float(disc.E[0]),
                                      nu=float(disc.nu[0]), plane=disc.plane,
                                      thickness=disc.thickness)
        tip, u_ex = point["uy"], exact["tip_deflection"]
        energy, e_ex = summary["strain_energy"], exact["strain_energy"]
        return {"type": kind, "tip_deflection": tip, "tip_deflection_exact": u_ex,
                "tip_deflection_rel_error": abs(tip - u_ex) / abs(u_ex),
                "strain_energy_exact": e_ex,
                "strain_energy_rel_error": abs(energy - e_ex) / abs(e_ex)}
    return {"type": kind}


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


def _centroid(mesh: Mesh, body: int) -> np.ndarray:
    return mesh.points[np.unique(mesh.quads[mesh.body == body])].mean(axis=0)


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
    if disc.method == "cs-fem" and disc.sd == 1:
        return (f"{detail}: CS-FEM-1SD has hourglass (zero-energy) modes{where} that the "
                "supports do not suppress; use --sd 2 or more (hourglass-free smoothing) or "
                "--method fem-q4")
    return f"{detail}: check that every body is held by supports{where}"
