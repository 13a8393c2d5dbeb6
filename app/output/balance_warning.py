"""A warning when a step leaves a body out of balance (summary `steps[k].balance`).

The balance is recomputed from the written displacement field, the loads, the support
reactions and the contact forces (app/output/reactions.py). Measured on every shipped
scene (configs/*.toml, configs/hard/*.toml, meshes/punch.toml) it stays at or below
1.2e-9 (hard/initial_gap, its steps with the gap open; every other scene below 2e-10).
A larger figure means the bodies' forces do not sum to zero: e.g. an LCP answer whose
error the consistency refinement moved into a floating body's equilibrium
(hard/tangential_contrast with q 1e-3 off: the core reads 9.1e-5), which the KKT checks
on the pairs no longer see.
"""

from __future__ import annotations

from app.assembly.solve import LOOSE_RESIDUAL

BALANCE_WARN = 1e-6
"""Largest `max_relative_residual` that passes without a warning (800 x the largest
measured on the shipped scenes, 1.2e-9; 11 x below the injected imbalance, 9.1e-5)."""


def balance_warning(balance: dict, step: int, solve_rel: float = 0.0) -> str | None:
    """The warning text for a step's `balance` (step 1-based), or None when its
    `max_relative_residual` is at most BALANCE_WARN. solve_rel: the relative residual of
    the run's iterative linear solves (0 for direct ones); above LOOSE_RESIDUAL the text
    names them as the likely cause (bonded.toml at --mesh-size 0.8 with -ksp_rtol 1e-6:
    solves at 3.9e-7, balance 1.2e-6 from step 13) instead of asking for a report."""
    worst = balance["max_relative_residual"]
    if worst <= BALANCE_WARN:  # (NaN warns too)
        return None
    bodies = balance.get("bodies", {})
    name = max(bodies, key=lambda b: bodies[b]["relative_residual"], default="?")
    head = (f"step {step}: body '{name}' is out of balance (relative residual {worst:.3g} "
            f"of its forces: loads, reactions, body force and contact; at most "
            f"{BALANCE_WARN:g} expected): the forces and displacements written do not "
            "satisfy its equilibrium; ")
    if solve_rel > LOOSE_RESIDUAL:
        return head + (f"the iterative linear solves (relative residual up to "
                       f"{solve_rel:.2e}) are the likely cause: tighten their tolerance "
                       "or use the default MUMPS LU")
    return head + ("rerun with the default MUMPS LU and --set analysis.warm_start=false, "
                   "and report it")
