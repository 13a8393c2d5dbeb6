"""The run driver: mesh -> discretisation -> assembly -> (contact) -> load steps -> output.

Every rank runs this; the mesh is built on rank 0 and broadcast; the stiffness is
distributed; the contact LCP is solved on rank 0 and its result broadcast. The phases
are functions in app/driver/ with typed results; `run` strings them together.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from petsc4py import PETSc

from app.assembly.solve import set_default_options
from app.config import Config
from app.driver.contact import condense, solve_contact_step
from app.driver.context import RunContext, RunOptions, run_timer, write_summary
from app.driver.linear import assemble_and_factor, unit_solutions
from app.driver.model import build_model, build_scene_mesh, make_discretisation
from app.driver.output import finish, open_output, superpose, write_step
from app.lcp.mip import CLOCK as SEARCH_CLOCK
from app.output.provenance import provenance
from app.output.status import RunGuard
from app.parallel import collective, to_numpy_all

__all__ = ["RunOptions", "build_scene_mesh", "collective", "make_discretisation", "run",
           "to_numpy_all", "write_summary"]

def run(cfg: Config, opts: RunOptions) -> dict:
    """Run a scene; returns the summary (also written to OUT/summary.json on rank 0).

    Every exit leaves OUT/summary.json with status completed, failed or interrupted
    (see app/output/status.py); a second run into the same OUT is refused.
    """
    set_default_options(cfg.petsc)
    summary = {"config": str(cfg.path), "n_steps": cfg.n_steps, "steps": [],
               "status": "running",
               "provenance": {**collective(provenance, cfg.raw, opts.overrides,
                                           PETSc.COMM_WORLD.getSize()),
                              "out": str(Path(opts.out).resolve())}}  # (out_owner)
    # inf and NaN from overflowing inputs are caught per step by check_finite
    timer = run_timer(opts)  # (the guard's `failed` / `interrupted` summary: its timings)
    with RunGuard(Path(opts.out), summary, write_summary, cfg.n_steps, timer), \
            np.errstate(over="ignore", invalid="ignore"):
        return _phases(RunContext(cfg, opts, summary, timer=timer))


def _phases(ctx: RunContext) -> dict:
    """The flow of a run, phase by phase (README, 'The method as built')."""
    SEARCH_CLOCK.new_run()                         # the mixed-integer search's budget
    model = build_model(ctx)                       # mesh, load cases, pairs, floating modes
    system = assemble_and_factor(ctx, model)       # stiffness, supports, one factorization
    unit = unit_solutions(ctx, model, system)      # K^-1 b per load case
    stepper = condense(ctx, model, system, unit) if model.contact is not None else None
    output = open_output(ctx, model, system)
    u = None
    for step in range(ctx.cfg.n_steps):
        started = time.perf_counter()
        SEARCH_CLOCK.new_step()
        u = superpose(ctx, model, unit.u, step)
        solved = None
        if model.contact is not None:              # the LCP, the consistency refinement
            solved = solve_contact_step(ctx, model, system, stepper, step, u,
                                        unit.step_forces[step])
            u = solved.u
        write_step(ctx, model, output, step, u, solved, started)
    return finish(ctx, model, output, u)           # closed-form errors, final summary
