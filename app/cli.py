"""Command line: `python -m app run CONFIG ...` (also under `mpiexec -n 2`).

Arguments the application does not know are PETSc options (-ksp_type, -pc_type,
-pc_factor_mat_solver_type, -log_view, -mat_mumps_icntl_14 ...).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path

from app.discretisation.methods import BULK_METHODS

DESCRIPTION = """\
2D multi-body elastic contact with CS-FEM (1/2/3/4/8/16 smoothing domains per element) or
FEM-Q4 on quadrilateral meshes, PETSc/MUMPS condensation onto the contact DOFs, and the
modified Coulomb interface law as an LCP solved by Lemke's method.

Any argument not listed below is passed to PETSc, for example
  -ksp_type cg -pc_type gamg              (an iterative solver instead of MUMPS LU)
  -pc_factor_mat_solver_type superlu_dist (another direct solver)
  -log_view                               (PETSc profile with the stages mesh, assembly,
                                           factorization, solve, compliance, lcp, output)
Run in parallel with: mpiexec -n 2 python -m app run CONFIG
"""


SET_HELP = ("override a config value (repeatable): a dotted key, entries of [[...]] arrays "
            "by name or 0-based index, a TOML value; e.g. --set interface.contact.mu=5 "
            "--set body.block.nu=0.499 --set analysis.steps=100")


ALLOW_LARGE_HELP = ("run even when the mesh estimated from the geometry and element sizes, "
                    "or the dense contact matrices once the pairs are known, need more memory "
                    "than this machine has (refused otherwise)")


def _parser() -> argparse.ArgumentParser:
    """The `python -m app` parser: subcommands run and study."""
    from app.startup.early_failure import Parser  # (its errors raise: recorded in OUT too)

    p = Parser(prog="python -m app", description=DESCRIPTION,
               formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="command", required=True)
    _run_parser(sub)
    _study_parser(sub)
    return p


def _run_parser(sub: argparse._SubParsersAction) -> None:
    """The `run` subcommand and its arguments."""
    r = sub.add_parser("run", help="solve one scene (a TOML config)",
                       description="Solve one scene and write OUT/results.xdmf, "
                       "OUT/contact.xdmf (if any contact), step_*.h5 and summary.json. "
                       "Unknown options go to PETSc.")
    r.add_argument("config", type=Path, help="scene file, e.g. configs/cantilever.toml")
    r.add_argument("--out", default=None,
                   help="output folder (default: out/<config name>)")
    r.add_argument("--method", choices=list(BULK_METHODS), default=None,
                   help="bulk discretisation (default: the config's analysis.method)")
    r.add_argument("--sd", type=int, default=None,
                   help="smoothing domains per element for cs-fem: 1, 2, 3, 4, 8 or 16")
    r.add_argument("--mesh-size", type=float, default=None, metavar="H",
                   help="global element size; every local refinement size is scaled by "
                   "H / mesh.size")
    r.add_argument("--mesh-cache", default=None,  # str: Path("") would be "."
                   help="folder where built meshes are cached and reused")
    r.add_argument("--allow-large", action="store_true", help=ALLOW_LARGE_HELP)
    r.add_argument("--refine", type=int, default=0, metavar="N",
                   help="split every quad of the (gmsh) mesh into four, N times (nested, "
                   "O(n); mid nodes on arcs go on the circle): N=4 gives 256x the elements")
    r.add_argument("--energy-bracket", action="store_true",
                   help="also solve with CS-FEM-1SD and/or FEM-Q4 (whichever the run is not) "
                   "and report the bracket of their strain energies, an a-posteriori error "
                   "estimate (summary key energy_bracket)")
    r.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help=SET_HELP)


CONVERGENCE_DEFAULTS = {"levels": 4, "first_level": 0, "methods": "1,2,3,4,8,16,q4",
                        "remesh": False, "reference_method": None, "reference": "richardson",
                        "reference_levels": 0}
"""Defaults of the study options that only a convergence study reads (not a --sweep)."""


def _study_parser(sub: argparse._SubParsersAction) -> None:
    """The `study` subcommand and its arguments (convergence study, or --sweep)."""
    s = sub.add_parser("study", help="convergence study: methods x refinement levels",
                       description="Refine level by level (each level splits every quad of "
                       "the level-0 mesh into four; --remesh: gmsh halves every element size) "
                       "and run every method; writes OUT/study.csv, study_tables.md (errors "
                       "against the closed form and against a model reference: Richardson "
                       "limits or the finest level of the reference method; observed orders, "
                       "energy bracket), richardson.csv and the plots "
                       "error_vs_dofs.png, error_vs_time.png, energy_vs_sd.png, "
                       "energy_bracket.png. The config needs a [reference] table (timoshenko, "
                       "hertz or cattaneo). With --sweep: a parameter study instead. Unknown "
                       "options go to PETSc.")
    s.add_argument("config", type=Path)
    s.add_argument("--levels", type=int, default=CONVERGENCE_DEFAULTS["levels"],
                   help="number of levels (default 4)")
    s.add_argument("--first-level", type=int, default=CONVERGENCE_DEFAULTS["first_level"],
                   help="first level (default 0)")
    s.add_argument("--methods", default=CONVERGENCE_DEFAULTS["methods"],
                   help="comma list of 1, 2, 3, 4, 8, 16 (CS-FEM SD) and q4 (FEM-Q4)")
    s.add_argument("--mesh-size", type=float, default=None, metavar="H",
                   help="global element size at level 0 (default: the config's mesh.size)")
    s.add_argument("--allow-large", action="store_true", help=ALLOW_LARGE_HELP)
    s.add_argument("--remesh", action="store_true",
                   help="mesh every level with gmsh (sizes scaled by 2^-level) instead of "
                   "splitting the level-0 mesh uniformly (the default: nested, O(n))")
    s.add_argument("--reference-method", default=CONVERGENCE_DEFAULTS["reference_method"],
                   metavar="LABEL",
                   help="method whose finest level is the model reference for the ref_* "
                   "errors, e.g. 4SD or FEM-Q4 (default 4SD if run, else the last method)")
    s.add_argument("--reference", default=CONVERGENCE_DEFAULTS["reference"],
                   choices=("richardson", "finest"),
                   help="model reference of the ref_* errors: richardson (default: energy, "
                   "p_max and point displacements extrapolated over the reference method's "
                   "last three levels, fields against its finest level; richardson.csv) or "
                   "finest (its finest level for everything)")
    s.add_argument("--reference-levels", type=int,
                   default=CONVERGENCE_DEFAULTS["reference_levels"], metavar="K",
                   help="the reference method alone also runs K levels finer than --levels "
                   "(default 0), so every other method's finest level has a finer reference")
    _sweep_arguments(s)
    s.add_argument("--out", default=None, help="default: out/study_<config>")
    s.add_argument("--quiet", action="store_true", help="no progress lines")
    s.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help=SET_HELP)


def _sweep_arguments(s: argparse.ArgumentParser) -> None:
    """The study arguments of a parameter sweep (--sweep, --at-step, --refine)."""
    s.add_argument("--sweep", action="append", default=[], metavar="KEY=V1,V2,...",
                   help="parameter study instead of a convergence study (repeatable; every "
                   "combination runs once): KEY is a config path as in --set, e.g. "
                   "interface.contact.mu=0.1,0.2,0.3; writes sweep.csv, sweep_steps.csv and "
                   "sweep_<key>.png")
    s.add_argument("--at-step", type=int, default=0, metavar="N",
                   help="with --sweep: the step whose forces and zones sweep.csv reports "
                   "(default 0: the last; negative counts back from the last)")
    s.add_argument("--refine", type=int, default=0, metavar="N",
                   help="with --sweep: uniform splits of the config mesh (as run --refine)")


def main(argv: list[str] | None = None) -> int:
    """`python -m app run|study ...`; returns the exit status (0, 2, 130 or 143). The
    process's end follows: from the return on, a signal exits at once (on several ranks an
    interrupted rank exits here), see app/output/late_signals.py."""
    parsed = _parse_command_line(list(sys.argv[1:] if argv is None else argv))
    if isinstance(parsed, int):  # a usage error, recorded
        return parsed
    args, petsc_args = parsed
    refused = _start(args, petsc_args)
    if refused is not None:
        return refused
    from petsc4py import PETSc

    from app import exit_sync

    rank = PETSc.COMM_WORLD.getRank()
    exit_sync.arm()
    message, code = _dispatch(args, petsc_args, rank)
    return _leave(rank, message, code)


def _parse_command_line(argv: list[str]) -> tuple[argparse.Namespace, list[str]] | int:
    """(the parsed arguments, the PETSc options), or the exit status of a usage error
    (argparse's lines printed, OUT/summary.json says failed)."""
    parser = _parser()
    # PETSc options that begin with -h (-help) would be taken as argparse's -h with a value
    petsc_h = [a for a in argv if a.startswith("-h") and a != "-h"]
    from app.startup.early_failure import UsageError, usage_failure

    try:
        args, petsc_args = parser.parse_known_args([a for a in argv if a not in petsc_h])
        petsc_args = petsc_h + petsc_args
        bad = [a for a in petsc_args if a.startswith("--")]
        if bad:
            parser.error(f"unknown option {bad[0]} (PETSc options take a single dash)")
    except UsageError as exc:  # argparse's lines, and OUT/summary.json says failed
        return usage_failure(exc, _parser, [a for a in argv if a not in petsc_h], _out_folder)
    return args, petsc_args


def _start(args: argparse.Namespace, petsc_args: list[str]) -> int | None:
    """The start-up signal handler armed and PETSc started; args.started and
    args.launched set (perf_counter at PETSc's start-up and at the process's start: the
    `startup` and `launch` phases). Exit status 2 when PETSc refused to start (rank 0
    says why, OUT/summary.json says failed), else None."""
    from app.output import startup_signals
    from app.startup.early_failure import record, study_head
    from app.startup.launch_time import process_start
    from app.startup.petsc import start_petsc

    launched = process_start()  # the `launch` phase, from the process's start
    startup_signals.set_clock(launched=launched)  # (a stop from here on: its timings)
    stem = args.config.stem if args.command == "run" else f"study_{args.config.stem}"
    startup_signals.arm(Path(args.out or Path("out") / stem), str(args.config),
                        head=None if args.command == "run" else study_head(
                            "sweep" if args.sweep else "convergence", args.config))

    refused = start_petsc(petsc_args)
    if refused:  # PETSc did not start: OUT/summary.json says failed (rank 0)
        startup_signals.restore()
        if startup_signals.launcher_rank() == 0:
            print(f"error: {record(args, refused, _out_folder)}", file=sys.stderr)
        return 2
    args.started = time.perf_counter()  # a run's `startup` phase counts from here
    args.launched = launched  # and its `launch` phase, from the process's start
    startup_signals.set_clock(started=args.started)
    return None


def _dispatch(args: argparse.Namespace, petsc_args: list[str], rank: int
              ) -> tuple[str | None, int]:
    """Run the command: (the `error:` line to print on rank 0 or None, the exit status).
    An unexpected exception leaves (on several ranks, not waiting for the others) with
    its traceback. The start-up signal handler is restored and the job's end armed."""
    from petsc4py import PETSc

    from app import exit_sync
    from app.errors import InputError, SolveError
    from app.output import late_signals, startup_signals
    from app.output.status import RunInterrupted
    from app.parallel import PeerFailure
    from app.petsc_options import petsc_error_line

    command = _study_command if args.command == "study" else _run_command
    late_signals.arm_outside()  # SIGTERM outside the runs' guards: as SIGINT
    message, code = None, 1
    try:
        code = command(args, petsc_args, rank)
    except (InputError, SolveError) as exc:
        message, code = f"error: {exc}", 2
    except RunInterrupted as exc:
        message, code = f"error: {exc}", exc.exit_code
    except KeyboardInterrupt:  # outside a run's guard (between a study's runs): no traceback
        from app.studies.batch_status import OUTSIDE_A_STEP

        message, code = f"error: {OUTSIDE_A_STEP}", 130
    except PETSc.Error as exc:
        message, code = f"error: PETSc: {petsc_error_line(exc)}", 2
    except PeerFailure as exc:  # rank 0 failed alone and says why (app/parallel.py)
        code = exc.code
    except Exception:  # a traceback: on several ranks, not while waiting for the others
        exit_sync.leave_if_alone(1, with_traceback=True)
        raise
    finally:
        startup_signals.restore()  # when no run's guard took the signals over
        late_signals.arm_end(code)  # the job's end: Python's, PETSc's and MPI's shutdown
    return message, code


def _leave(rank: int, message: str | None, code: int) -> int:
    """Print the `error:` line (rank 0), leave at once after a failure on a rank the others
    do not wait for, and hand `code` to the process's end."""
    from app import exit_sync
    from app.output import late_signals

    if rank == 0 and message is not None:
        print(message, file=sys.stderr)
    if code in (1, 2):  # a failure: do not wait in MPI_Finalize for a rank that never ends
        exit_sync.leave_if_alone(code, message)
    late_signals.leave(code)
    return code


def _study_command(args, petsc_args: list[str], rank: int) -> int:
    """`study`: a convergence study, or a parameter study with --sweep; OUT/summary.json
    says completed, failed or interrupted (app/studies/batch_status.py)."""
    from app.studies.batch_status import BatchStatus

    with BatchStatus("sweep" if args.sweep else "convergence", args.config, list(args.set),
                     _judged_out_folder(args, Path("out") / f"study_{args.config.stem}"),
                     launched=args.launched, started=args.started) as batch:
        rows, out = _study_rows(args, batch)
        batch.completed(len(rows), "sweep.csv" if args.sweep else "study.csv")
    if rank == 0 and not args.quiet:
        print(f"{len(rows)} {'rows' if args.sweep else 'runs'} -> "
              f"{out / ('sweep.csv' if args.sweep else 'study.csv')}", file=sys.stderr)
    return 0


def _out_folder(args, default: Path):
    """A function that gives --out (or `default`) created and checked, to record bad input
    in; None when there is nothing to write (no --out and a config that is no file)."""
    if args.out is None and not os.path.isfile(args.config):
        return None
    return lambda: output_folder(args.out, default)


def _study_rows(args, batch) -> tuple[list[dict], Path]:
    """The checks of the study's options, then its runs; the rows and OUT."""
    from app.config import load_config
    from app.errors import InputError
    from app.studies.batch_status import shared_start_line
    from app.studies.convergence import parse_methods, run_study

    cfg = load_config(args.config, args.set)
    if args.levels < 1 or args.first_level < 0:
        raise InputError("--levels must be >= 1 and --first-level >= 0")
    if not 0 <= args.reference_levels <= 3:
        raise InputError(f"--reference-levels must be 0..3 (got {args.reference_levels})")
    if not args.sweep and (args.at_step or args.refine):  # (they were silently ignored)
        raise InputError("--at-step and --refine apply with --sweep only (a convergence "
                         "study refines by --levels and --first-level)")
    given = ["--" + k.replace("_", "-") for k, v in CONVERGENCE_DEFAULTS.items()
             if getattr(args, k) != v]
    if args.sweep and given:  # (a sweep ignored them silently)
        raise InputError(f"{given[0]} does not apply with --sweep (a sweep runs the config's "
                         "method at --refine; set analysis.method / analysis.sd with --set)")
    finest = (args.refine if args.sweep
              else args.first_level + args.levels - 1 + args.reference_levels)
    # a sweep's runs are checked each for its groups (app/studies/sweep.py): the swept
    # key may replace the base config's name in every run (a template's placeholder)
    scale = check_run_input(cfg, args, finest, _study_runs(args, finest),
                            groups=not args.sweep)
    if args.sweep:
        from app.studies.sweep import parse_sweeps, run_sweep

        if not 0 <= args.refine <= 8:
            raise InputError(f"--refine must be 0..8 (got {args.refine})")
        sweeps = parse_sweeps(args.sweep)
        out = batch.open(cfg)
        return run_sweep(args.config, args.set, sweeps, out,
                         {"mesh_scale": scale, "mesh_cache": out / "mesh_cache",
                          "refine": args.refine, "allow_large": args.allow_large},
                         args.at_step, args.quiet), out
    methods = parse_methods(args.methods)
    out = batch.open(cfg)
    rows = run_study(cfg, out, args.levels, methods, scale,
                     args.quiet, args.first_level, args.remesh, args.reference_method,
                     args.reference, args.reference_levels, tuple(args.set),
                     allow_large=args.allow_large,
                     timing=shared_start_line(batch.summary.get("timings", {})))
    if not rows:
        raise InputError(f"every run of the study failed (see the lines above and "
                         f"{out}/*/summary.json)")
    return rows, out


def _study_runs(args, finest: int) -> list[float]:
    """A study's runs, each as its DOFs over its finest level's: a sweep's combinations
    (at one level), or every method at each level and the reference method alone at the
    --reference-levels beyond (4^(level - finest) each)."""
    import math

    if args.sweep:
        from app.studies.sweep import parse_sweeps

        return [1.0] * math.prod(len(v) for _, v in parse_sweeps(args.sweep))
    from app.studies.convergence import parse_methods

    n = len(parse_methods(args.methods))
    return [4.0 ** (level - finest) for level in range(args.first_level, finest + 1)
            for _ in range(n if level <= finest - args.reference_levels else 1)]


def _run_command(args, petsc_args: list[str], rank: int) -> int:
    """`run`: one scene, then the unused PETSc options and the closing line."""
    from app.config import load_config
    from app.errors import InputError
    from app.output.progress import final_line
    from app.output.status import RunInterrupted
    from app.run import RunOptions, run, write_summary

    default_out = Path("out") / args.config.stem
    try:  # bad input found here is recorded in OUT/summary.json too
        cfg = load_config(args.config, args.set)
        if not 0 <= args.refine <= 8:
            raise InputError(f"--refine must be 0..8 (got {args.refine})")
        scale = check_run_input(cfg, args, args.refine)
        opts = RunOptions(out=_judged_output_folder(args.out, default_out),
                          method=args.method, sd=args.sd, mesh_scale=scale, quiet=args.quiet,
                          mesh_cache=args.mesh_cache and Path(args.mesh_cache),
                          overrides=list(args.set),
                          refine=args.refine, started=getattr(args, "started", None),
                          launched=getattr(args, "launched", None),
                          allow_large=args.allow_large)
        method = opts.method or cfg.method  # (--sd with a config's fem-q4 was ignored)
        if args.sd is not None and method in BULK_METHODS \
                and not BULK_METHODS[method].sd_choices:
            where = "--method" if opts.method else "analysis.method ="
            raise InputError(f"--sd does not apply to {where} {method}")
    except InputError as exc:
        from app.startup.input_failure import record_input_failure

        record_input_failure(exc, _judged_out_folder(args, default_out), args.config,
                             list(args.set))
    try:
        summary = run(cfg, opts)
    except RunInterrupted as exc:  # the closing line, then the one-line error in main
        if rank == 0 and exc.summary is not None and not args.quiet:
            print(final_line(exc.summary, opts.out), file=sys.stderr)
        raise
    if args.energy_bracket:
        from app.studies.energy_bracket import add_energy_bracket

        summary = add_energy_bracket(cfg, opts, summary)
    unused = warn_unused_options(cfg, petsc_args, rank)
    if unused:
        summary["petsc_options_unused"] = unused
        if rank == 0:
            write_summary(opts.out, summary)
    if rank == 0 and not args.quiet:
        print(final_line(summary, opts.out), file=sys.stderr)
        _print_bracket(summary.get("energy_bracket"))
    return 0


def _print_bracket(b: dict | None) -> None:
    """The energy bracket line of `run --energy-bracket`."""
    if b:
        print(f"energy bracket: {b['error']}" if "error" in b else
              f"energy bracket: {b['lower']:.10g} ({b['lower_method']}) <= U <= "
              f"{b['upper']:.10g} ({b['upper_method']}), width {b['width_rel']:.3e} "
              "relative", file=sys.stderr)


def check_run_input(cfg, args, finest_level: int = 0, runs: list[float] | None = None,
                    groups: bool = True) -> float:
    """Checks of the command line against the config before any work; returns the mesh
    size scale (--mesh-size / mesh.size). Raises InputError (one line). `runs`: a
    study's runs, each as its DOFs over the finest level's (the disk check). groups:
    whether the supports' and loads' groups are checked (False: a sweep's, run by run)."""
    from app.assembly.loads import check_groups_before_meshing
    from app.parallel import rank0_call
    from app.petsc_options import check_log_view_file, check_solver_options

    if groups:
        check_groups_before_meshing(cfg)  # (the config's own: alike on every rank)
    check_solver_options(cfg.petsc)
    check_log_view_file(cfg.petsc)  # (collective: rank 0 judges, all drop a bad -log_view)
    return rank0_call(_judged_run_input, cfg, args, finest_level, runs)


def _judged_run_input(cfg, args, finest_level: int, runs: list[float] | None) -> float:
    """check_run_input's checks that read the file system (mesh.file, --mesh-cache, the
    free disk) or the machine: on rank 0 only, its verdict broadcast (rank0_call). Before,
    every rank judged for itself: a rank that came later could find what rank 0, failing,
    had made (OUT, to record the failure: mesh.file `OUT/../m.msh`), pass, and go on into
    the run alone: the job hung or ended in tracebacks (tests/test_input_checks_ranks.py)."""
    from app.errors import InputError
    from app.mesh.estimate import check_disk, check_resolution, check_size

    file = cfg.scene.file
    if args.mesh_size is not None:
        if not args.mesh_size > 0 or args.mesh_size == float("inf"):
            raise InputError(f"--mesh-size must be a number > 0 (got {args.mesh_size})")
        if file is not None:
            raise InputError(f"--mesh-size does not apply to a mesh read from mesh.file "
                             f"({file}): refine that mesh in gmsh instead")
    if getattr(args, "remesh", False) and file is not None:  # else every level read the file
        raise InputError(f"--remesh does not apply to a mesh read from mesh.file ({file}): "
                         "gmsh cannot mesh it anew; leave --remesh out and the levels split it")
    cache = getattr(args, "mesh_cache", None)
    if cache is not None:
        if file is not None:
            raise InputError("--mesh-cache does not apply to a mesh read from mesh.file")
        output_folder(str(cache), Path(cache), what="--mesh-cache")
    scale = args.mesh_size / cfg.mesh_size if args.mesh_size else 1.0
    check_resolution(cfg.scene, scale * 2.0**-finest_level,  # splits follow the arcs
                     given=args.mesh_size or cfg.mesh_size,
                     option="--mesh-size" if args.mesh_size else "mesh.size")
    est = check_size(cfg.scene, scale * 2.0**-finest_level, allow_large=args.allow_large,
                     base_dir=cfg.path.parent, refine=finest_level)
    check_disk(est, cfg.n_steps, args.out or "out", allow_large=args.allow_large, runs=runs)
    return scale


def _judged_output_folder(text: str | None, default: Path) -> Path:
    """output_folder on rank 0, its verdict (the folder or the InputError) every rank's
    (after PETSc's start). Before, each rank checked --out for itself: with ranks whose
    file systems differ (a relative --out, ranks started in other folders or on other
    nodes), a rank that refused it failed alone while rank 0 went into the run: the job
    ended 35 s later with OUT/summary.json still `running` (tests/test_input_checks_ranks.py).
    Only rank 0 writes into OUT."""
    from app.parallel import rank0_call

    return rank0_call(output_folder, text, default)


def _judged_out_folder(args, default: Path) -> Callable[[], Path] | None:
    """_out_folder after PETSc's start: whether there is a folder, and the folder or its
    InputError, are rank 0's verdicts, every rank's (as _judged_output_folder)."""
    from app.parallel import rank0_call

    if rank0_call(lambda: _out_folder(args, default) is None):
        return None
    return lambda: _judged_output_folder(args.out, default)


def output_folder(text: str | None, default: Path, what: str = "--out") -> Path:
    """The folder `text` (or `default` when None), created and checked writable."""
    import tempfile

    from app.errors import InputError
    from app.user_paths import path_kind

    if text is not None and not str(text).strip():
        raise InputError(f"{what} is empty: give a folder name")
    path = Path(text) if text is not None else default
    if path_kind(path, what) not in (None, "dir"):
        raise InputError(f"{what} {path} exists and is not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".write_test_", dir=path)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(f"{what} {path}: cannot write there ({exc.strerror or exc})") from None
    return path


def warn_unused_options(cfg, petsc_args: list[str], rank: int) -> list[str]:
    """Print the user's PETSc options that nothing used (like -options_left) on stderr."""
    from app.petsc_options import unused_options

    user = {a.lstrip("-") for a in petsc_args if a.startswith("-") and len(a) > 1
            and not a[1:2].isdigit() and not a.startswith("-.")}
    if cfg is not None:
        user |= set(cfg.petsc)
    unused = unused_options(user)
    if unused and rank == 0:
        print(f"warning: PETSc options not used (misspelled?): {' '.join(unused)}",
              file=sys.stderr)
    return unused
