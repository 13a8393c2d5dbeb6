"""Run under mpiexec by tests/test_parallel_edge_cases.py: `python -m app ARGS` with one
function made to raise on one rank only, as a bug or a shortage on that rank alone would.
argv[1] is WHERE:EXCEPTION[:RANK[:SECONDS]] (WHERE one of INJECT_AT, RANK 0 unless given;
SECONDS: app/exit_sync.py's OTHER_SECONDS instead of its 30 s), the rest the app's
arguments."""

from __future__ import annotations

import sys

INJECT_AT = {  # where: (module, attribute) of a function that runs on rank 0 alone
    "mesh": ("app.driver.model", "build_scene_mesh"),  # rank0_call
    "lcp": ("app.interface.steps", "ContactStepper.step"),  # rank0_call, each step
    "contact_output": ("app.driver.output", "contact_arrays"),  # rank 0's step output
    "write": ("app.driver.output", "_write_step"),  # on_rank0, the step files
    "schur_factor": ("app.condensation.schur_solver", "DenseFactor"),  # S, dense
    "compliance": ("app.condensation.compliance", "dense_compliance"),  # C, Schur route
    "symmetrise": ("app.condensation.compliance", "symmetric_part"),  # C, solve route
    "fields": ("app.driver.output", "element_fields"),  # every rank, its own elements
}
EXCEPTIONS = {"ValueError": ValueError, "IndexError": IndexError,
              "MemoryError": MemoryError, "RuntimeError": RuntimeError}


def inject(where: str, exc_name: str, rank: str = "0") -> None:
    """Replace the function at `where` by one that raises on rank `rank`."""
    import importlib

    module_name, attr = INJECT_AT[where]
    owner = importlib.import_module(module_name)
    *path, name = attr.split(".")
    for part in path:
        owner = getattr(owner, part)
    original = getattr(owner, name)

    def failing(*args, **kwargs):
        from petsc4py import PETSc

        if PETSc.COMM_WORLD.getRank() == int(rank):
            raise EXCEPTIONS[exc_name](f"injected at {where}")
        return original(*args, **kwargs)

    setattr(owner, name, failing)


def start_then_inject(where: str, exc_name: str, rank: str = "0",
                      seconds: str | None = None) -> None:
    """Inject once PETSc has started with the run's options (the modules patched import
    petsc4py's PETSc, which must not start before)."""
    import app.startup.petsc as petsc_start

    if seconds is not None:
        import app.exit_sync

        app.exit_sync.OTHER_SECONDS = float(seconds)

    start = petsc_start.start_petsc

    def started(petsc_args):
        refused = start(petsc_args)
        if refused is None:
            inject(where, exc_name, rank)
        return refused

    petsc_start.start_petsc = started


if __name__ == "__main__":
    start_then_inject(*sys.argv[1].split(":"))
    from app.cli import main

    sys.exit(main(sys.argv[2:]))
