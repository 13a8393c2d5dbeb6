"""Phase 1, build the model: the bulk method, the mesh, the load cases, the supports, the
contact constraints and the modes of bodies held only by contact."""

from __future__ import annotations

import sys
from dataclasses import dataclass, field

import numpy as np

from app.assembly.loads import LoadCase, constrained_dofs, load_cases
from app.condensation.dense_size import check_dense_contact
from app.config import Config
from app.contact.discretisation import contact_discretisation
from app.discretisation.bulk import Discretisation, check_elements, locking_warnings
from app.discretisation.methods import bulk_method
from app.driver.context import RunContext, RunOptions
from app.errors import InputError
from app.interface.contact import ContactSetup
from app.interface.floating import FloatingModes, floating_modes
from app.lcp.solvers import lcp_solver
from app.mesh.estimate import BYTES_PER_DOF, machine_memory
from app.mesh.model import Mesh
from app.output.status import arm_signals
from app.parallel import collective


@dataclass
class Model:
    """The discretised scene: mesh, bulk method, load cases, prescribed DOFs (`fixed`, and
    `fixed_all` with the pins of floating modes), contact (None without interfaces)."""

    mesh: Mesh
    disc: Discretisation
    cases: list[LoadCase]
    fixed: np.ndarray
    fixed_all: np.ndarray
    contact: ContactSetup | None
    floating: FloatingModes | None
    watches: list = field(default_factory=list)
    """per interface, the undeformed half of the crossing checks (app/driver/contact.py
    `_watches`, built at the first step): (unpaired slave nodes, master nodes) Watches"""

    @property
    def n_dofs(self) -> int:
        return 2 * self.mesh.n_nodes


def make_discretisation(cfg: Config, opts: RunOptions) -> Discretisation:
    """The bulk method and materials; the method and sd checked against the registry."""
    method = bulk_method(opts.method or cfg.method,
                         "--method" if opts.method else "analysis.method")
    sd = method.check_sd(opts.sd if opts.sd is not None else cfg.sd,
                         "--sd" if opts.sd is not None else "analysis.sd")
    return Discretisation(method.name, sd, cfg.plane, cfg.thickness, cfg.E, cfg.nu)


def build_scene_mesh(cfg: Config, opts: RunOptions) -> Mesh:
    """The checked mesh of the scene: gmsh (or mesh.file), then `opts.refine` splits."""
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


def build_model(ctx: RunContext) -> Model:
    """Phases mesh, setup, pair_search and floating_modes; fills the summary's sizes."""
    cfg, opts = ctx.cfg, ctx.opts
    disc = make_discretisation(cfg, opts)
    for text in locking_warnings(disc, cfg.body_names):
        ctx.warn(text)
    for itf in cfg.interfaces:  # the contact discretisations, checked before any meshing
        contact_discretisation(itf.discretisation, f"interface '{itf.name}'")
    lcp_solver(cfg.lcp_solver)
    with ctx.phase("mesh"):
        mesh = collective(build_scene_mesh, cfg, opts)
        arm_signals()  # gmsh.finalize() put back the default SIGTERM action
        _mesh_quality(mesh, ctx.summary, opts.quiet or ctx.rank != 0)
    if cfg.scene.file is None:
        from app.mesh.estimate import one_element_bodies

        for text in one_element_bodies(cfg.scene, opts.mesh_scale * 2.0**-opts.refine):
            ctx.warn(text)
    if cfg.scene.file is not None and opts.refine:  # its curved sides stay chords
        from app.mesh.facets import faceted_split_warnings

        for text in faceted_split_warnings(mesh, str(cfg.scene.file), opts.refine):
            ctx.warn(text)
    _describe(ctx, mesh, disc)
    with ctx.phase("setup"):
        cases = load_cases(mesh, cfg)
        fixed = constrained_dofs(mesh, cfg)
    contact = None
    if cfg.interfaces:
        with ctx.phase("pair_search"):
            contact = ContactSetup.build(mesh, cfg)
            contact.hold(mesh, fixed)
            # before S is formed; rank 0's machine judges, where the dense block lives
            # (each rank's own verdict split nodes of different memory: one refused alone)
            collective(lambda: check_dense_contact(contact.g, fixed, BYTES_PER_DOF * 2
                                                   * mesh.n_nodes, machine_memory(),
                                                   opts.allow_large))
        ctx.summary["n_pairs"] = contact.pairs.n_pairs
        for text in contact.warnings:
            ctx.warn(text)
        ctx.summary["contact_interfaces"] = contact.described
    with ctx.phase("floating_modes"):  # with CS-FEM-1SD: the hourglass eigen-solve
        floating = floating_modes(mesh, cfg, fixed, contact, disc)
        pins = floating.pins if floating else np.zeros(0, dtype=np.int64)
    with ctx.phase("setup"):
        for text in _prescribed_load_warnings(cases, fixed):
            ctx.warn(text)
    return Model(mesh, disc, cases, fixed, np.union1d(fixed, pins), contact, floating)


def _describe(ctx: RunContext, mesh: Mesh, disc: Discretisation) -> None:
    """The run's sizes and method in the summary; every config body must have elements."""
    cfg = ctx.cfg
    ctx.summary.update({
        "config": str(cfg.path), "method": disc.method,
        "sd": disc.sd if disc.bulk.sd_choices else None, "label": disc.label,
        "plane": disc.plane, "ranks": ctx.size, "n_nodes": mesh.n_nodes,
        "n_dofs": 2 * mesh.n_nodes, "n_elements": mesh.n_elements,
        "n_bodies": len(mesh.body_names), "bodies": mesh.body_names,
        "n_steps": cfg.n_steps, "steps": [], "status": "running",
    })
    for name in cfg.body_names:
        if name not in mesh.body_names:
            raise InputError(f"body '{name}' has no elements in the mesh")


def _mesh_quality(mesh: Mesh, summary: dict, quiet: bool) -> None:
    """Degenerate or non-convex elements are an error; else one line and summary.json."""
    from app.mesh.quality import mesh_quality, quality_line

    summary["mesh_quality"] = mesh_quality(mesh)
    if not quiet:
        print(quality_line(summary["mesh_quality"]), file=sys.stderr, flush=True)


def _prescribed_load_warnings(cases: list[LoadCase], fixed: np.ndarray) -> list[str]:
    """Loads acting on prescribed DOFs go straight into the support reaction: say so."""
    out = []
    for case in cases:
        on_fixed = case.rhs[fixed]
        roundoff = 1e-8 * np.abs(case.rhs).max(initial=0.0)  # a pressure normal to the DOF
        if np.any(np.abs(on_fixed) > roundoff):
            out.append(f"{case.name}: {np.count_nonzero(np.abs(on_fixed) > roundoff)} of its "
                       "nodal forces act on "
                       f"prescribed DOFs (sum {np.abs(on_fixed).sum():.4g}) and are taken by "
                       "the supports, not by the bodies; see steps[k].reactions")
    return out
