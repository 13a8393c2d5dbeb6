"""Convergence studies: every method at every refinement level, timed and checked against
the scene's closed form. Writes study.csv and PNG plots (matplotlib, Agg).

Level l is the level-0 mesh (the config's, element sizes scaled by base_scale) split
uniformly l times (app/mesh/refine.py: nested levels, O(n) meshing, h halves per level);
with remesh=True gmsh meshes every level anew with every element size scaled by
base_scale * 2**-l. Meshes are cached and reused across methods and reruns.

Besides the errors against the closed form (`err_*`), every run is compared with a
reference of the same model (`ref_*`, app/studies/reference_errors.py), so the comparison
has no model error: by default the Richardson limits of the reference method's (default
4SD) energy, peak pressure and point displacements and its finest level for the fields
(app/studies/richardson_reference.py); with reference_mode="finest" its finest level for
all. Observed orders between successive levels (`order_*`), the energy bracket U(1SD) /
U(FEM-Q4 or 16SD) per level and a markdown table are written next to study.csv.
"""

from __future__ import annotations

import csv
import io
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from petsc4py import PETSc

from app.config import Config
from app.discretisation.methods import BULK_METHODS
from app.errors import InputError, SolveError
from app.output.batch_guard import BatchGuard
from app.output.status import step_writing
from app.output.xdmf import atomic_write_bytes
from app.plotting import pyplot
from app.references import REFERENCES
from app.run import RunOptions, run
from app.studies.level_mesh import build_level_mesh
from app.studies.missing_runs import level_tag, missing_runs, planned_runs
from app.studies.reference_errors import (
    add_reference_errors,
    energy_bracket,
    fitted_rate,
    plot_bracket,
    profile,
    write_tables,
)
from app.studies.richardson_reference import (
    REFERENCE_MODES,
    add_limit_spread,
    method_limits,
    order_marks,
    order_summary,
    reference_scalars,
    tables,
)

PHASES = ("mesh", "assembly", "factorization", "solve", "pair_search", "compliance", "lcp",
          "recovery", "output", "total")


def parse_methods(text: str) -> list[tuple[str, int]]:
    """'1,2,4,q4' -> [("cs-fem", 1), ("cs-fem", 2), ("cs-fem", 4), ("fem-q4", 4)].

    A bare number is a CS-FEM smoothing-domain count; other names come from the
    bulk-method registry (`BulkMethod.study_names`). A method named twice (e.g. "4,4" or
    "q4,fem-q4") runs once: each run writes the folder L<level>_<label>.
    """
    names = {n: (m.name, 4) for m in BULK_METHODS.values() for n in m.study_names}
    sds = BULK_METHODS["cs-fem"].sd_choices
    out = []
    for item in text.split(","):
        item = item.strip().lower()
        if item in names:
            out.append(names[item])
        elif item.isdigit() and int(item) in sds:
            out.append(("cs-fem", int(item)))
        else:
            choices = ", ".join([*map(str, sds), *names])
            raise InputError(f"--methods: '{item}' is not one of {choices}")
    return list(dict.fromkeys(out))


def label(method: str, sd: int) -> str:
    """The study's short label, e.g. "4SD" or "FEM-Q4"."""
    return BULK_METHODS[method].short(sd)


def run_study(cfg: Config, out: Path, levels: int, methods: list[tuple[str, int]],
              base_scale: float = 1.0, quiet: bool = False, first_level: int = 0,
              remesh: bool = False, reference: str | None = None,
              reference_mode: str = "richardson", reference_levels: int = 0,
              overrides: tuple[str, ...] = (), allow_large: bool = False,
              timing: str = "") -> list[dict]:
    """Run every (level, method); returns the rows written to OUT/study.csv.

    reference: label of the reference method (default 4SD if run, else the last method).
    reference_mode: "richardson" (its scalars extrapolated over its levels,
    app/studies/richardson_reference.py) or "finest" (its finest level). reference_levels:
    the reference method alone also runs that many levels finer than the others, so that
    their finest levels are compared with a finer reference. overrides: the `--set`
    strings already in cfg, recorded in each run's provenance. allow_large: as run's
    --allow-large (the dense contact check of each run). timing: the line under the
    tables that says how t_total is counted (batch_status.shared_start_line). Raises
    SolveError if every run fails.
    """
    columns, ref_label = _study_reference(cfg, methods, reference, reference_mode)
    study = ConvergenceStudy(cfg, Path(out), methods, columns, ref_label, reference_mode,
                      first_level, first_level + levels - 1 + reference_levels,
                      reference_levels, base_scale, remesh, quiet, list(overrides),
                      allow_large, timing=timing)
    with BatchGuard(lambda: _write_completed(study)):
        for level in range(first_level, study.last + 1):
            _run_level(study, level)
    if not study.rows:
        raise SolveError(f"every run of the study failed ({len(study.failures)} runs; first: "
                         f"{study.failures[0].splitlines()[0] if study.failures else 'none'})")
    if PETSc.COMM_WORLD.getRank() == 0:
        finish_study(cfg, study.out, study.rows, study.profiles, ref_label, reference_mode,
                     quiet, study.failures, timing=study.timing)
    return study.rows


@dataclass
class ConvergenceStudy:
    """One convergence study: what it runs (levels first_level..last; the levels above
    last - reference_levels run the reference method only) and, as it goes, the rows, the
    profiles of the runs recorded on rank 0 and the failed runs' messages."""

    cfg: Config
    out: Path
    methods: list[tuple[str, int]]
    columns: list  # the err_* columns of the reference type
    ref_label: str
    reference_mode: str
    first_level: int
    last: int
    reference_levels: int
    base_scale: float
    remesh: bool
    quiet: bool
    overrides: list[str]
    allow_large: bool
    rows: list[dict] = field(default_factory=list)
    profiles: dict[tuple[int, str], dict] = field(default_factory=dict)
    failures: list[str] = field(default_factory=list)
    timing: str = ""  # the tables' line on how t_total is counted
    t0: float = field(default_factory=time.perf_counter)  # progress lines' clock
    started: float = field(default_factory=lambda: time.time() - 0.1)  # (file times: coarse)


def _run_level(study: ConvergenceStudy, level: int) -> None:
    """The level's mesh (built first, so that no run pays gmsh), then each of its runs."""
    scale = study.base_scale * 2.0**-level if study.remesh else study.base_scale
    # the mesh's progress line: every level's with remesh, else level 0's (the one meshed)
    shown = not study.quiet and (study.remesh or level == study.first_level)
    gmsh_s = build_level_mesh(study.cfg, scale, study.out / "mesh_cache",
                              level_tag(level, study.first_level, study.last) if shown else None)
    for method, sd in study.methods:
        if level > study.last - study.reference_levels and label(method, sd) != study.ref_label:
            continue  # finer levels: the reference method only
        opts = _run_options(study, level, method, sd, scale)
        s = _try_run(study.cfg, opts, study.failures, study.t0)
        if s is not None:
            _add_row(study, s, opts, level, label(method, sd), gmsh_s)


def _run_options(study: ConvergenceStudy, level: int, method: str, sd: int,
                 scale: float) -> RunOptions:
    """The options of the run of (level, method): its folder OUT/L<level>_<label>, the
    study's mesh cache and the level's refinement (or, with remesh, its mesh scale)."""
    return RunOptions(out=study.out / f"L{level}_{label(method, sd)}", method=method,
                      sd=sd, mesh_scale=scale, quiet=study.quiet,
                      mesh_cache=study.out / "mesh_cache",
                      progress_prefix=f"{level_tag(level, study.first_level, study.last)} "
                                      f"{label(method, sd)}",
                      refine=0 if study.remesh else level, overrides=list(study.overrides),
                      allow_large=study.allow_large)


def _add_row(study: ConvergenceStudy, s: dict, opts: RunOptions, level: int, method: str,
             gmsh_s: float) -> None:
    """A completed run's row; on rank 0 also its profile, study.csv and the tables so
    far. An interrupt waits until the row is recorded."""
    step_writing(True)
    try:
        study.rows.append(study_row(s, level, method, study.columns)
                          | {"t_level_gmsh": gmsh_s})
        if PETSc.COMM_WORLD.getRank() == 0:
            _record_row(study.out, study.rows, study.profiles, s, opts, study.t0)
            _refresh_tables(study.cfg, study.out, study.rows, study.profiles, study.ref_label,
                            study.reference_mode, study.failures, study.timing)
    finally:
        step_writing(False)


def _write_completed(study: ConvergenceStudy) -> str:
    """On SIGINT / SIGTERM (rank 0): the tables and plots of the runs that completed, with
    the runs that did not listed; returns the one-line account."""
    out = study.out
    done = [dict(r) for r in study.rows if (r["level"], r["method"]) in study.profiles]
    if not done:  # (a row without its profile: stopped while it was recorded)
        return f"study: no run completed in {out}"
    plots = PETSc.COMM_WORLD.getSize() == 1  # several ranks: mpiexec kills in 1 s
    plan = planned_runs(study.first_level, study.last, study.reference_levels,
                        [label(m, sd) for m, sd in study.methods], study.ref_label)
    missing = missing_runs(out, plan, {(r["level"], r["method"]) for r in done},
                           study.failures, study.last, since=study.started)
    finish_study(study.cfg, out, done, dict(study.profiles), study.ref_label,
                 study.reference_mode, True, study.failures + missing, plots=plots,
                 timing=study.timing)
    return (f"study: interrupted; the {len(done)} completed runs are in study.csv and "
            f"study_tables.md" + (", and the plots" if plots else
                                  " (no plots on several ranks)") + f", in {out}; "
            f"study_tables.md lists the {len(missing)} runs that did not complete")


def _study_reference(cfg: Config, methods: list[tuple[str, int]], reference: str | None,
                     reference_mode: str) -> tuple[list, str]:
    """The err_* columns of the config's reference type and the reference method's label;
    InputError for an unknown reference_mode, a config without [reference] or a
    reference method that is not run."""
    if reference_mode not in REFERENCE_MODES:
        raise InputError(f"--reference must be one of {', '.join(REFERENCE_MODES)}")
    if cfg.reference is None:
        raise InputError(f"{cfg.path}: a study needs a [reference] table with type one of "
                         f"{sorted(REFERENCES)}")
    columns = REFERENCES[cfg.reference["type"]].columns
    labels = [label(m, sd) for m, sd in methods]
    if reference is not None and reference not in labels:
        raise InputError(f"--reference-method {reference} is not among the methods "
                         f"({', '.join(labels)})")
    return columns, reference or ("4SD" if "4SD" in labels else labels[-1])


def _try_run(cfg: Config, opts: RunOptions, failures: list[str], t0: float) -> dict | None:
    """The summary of one study run, or None if it raised SolveError (the message is
    appended to failures and, on rank 0 unless quiet, printed; t0: the study's start)."""
    tag = opts.progress_prefix
    try:
        return run(cfg, opts)
    except SolveError as exc:
        failures.append(f"{tag}: {exc}")
        if PETSc.COMM_WORLD.getRank() == 0 and not opts.quiet:
            print(f"[{time.perf_counter() - t0:8.2f} s] {tag}: failed: {exc}", flush=True)
        return None


def _record_row(out: Path, rows: list[dict], profiles: dict, s: dict, opts: RunOptions,
                t0: float) -> None:
    """Rank 0, after a run whose row is rows[-1] (summary s): its profile, study.csv
    rewritten, and the progress line unless quiet (t0: the study's start)."""
    row = rows[-1]
    profiles[(row["level"], row["method"])] = profile(s, opts.out)
    write_csv(out / "study.csv", rows)
    if not opts.quiet:
        errs = ", ".join(f"{k[4:]} {row[k]:.3e}" for k in row if k.startswith("err_"))
        print(f"[{time.perf_counter() - t0:8.2f} s] {opts.progress_prefix}: "
              f"{row['n_dofs']} DOFs, {row['t_total']:.2f} s, {errs}", flush=True)


def _refresh_tables(cfg: Config, out: Path, rows: list[dict], profiles: dict, ref_label: str,
                    reference_mode: str, failures: list[str], timing: str = "") -> None:
    """Rank 0, after each completed run: the tables of the runs so far (no plots), so that
    an interrupt leaves them. A failure here is a warning: the study goes on (an exception
    on rank 0 alone would end a study on several ranks), and the final tables are written
    at its end as always."""
    try:
        finish_study(cfg, out, [dict(r) for r in rows], profiles, ref_label, reference_mode,
                     True, failures, plots=False, timing=timing)
    except Exception as exc:  # a warning; the end of the study reports it
        print(f"warning: the study's tables could not be refreshed after this run "
              f"({type(exc).__name__}: {exc}); the study goes on", file=sys.stderr,
              flush=True)


def study_row(s: dict, level: int, method: str, columns) -> dict:
    """One study.csv row from a run's summary: sizes, phase seconds, pivots and the
    err_* columns of the reference type (`columns`: (summary path, name) pairs)."""
    row = {"level": level, "method": method, "n_dofs": s["n_dofs"],
           "n_elements": s["n_elements"], "n_pairs": s.get("n_pairs", 0),
           "ranks": s["ranks"], "strain_energy": s["strain_energy"]}
    for ph in dict.fromkeys([*PHASES[:-1], *s["timings"], "total"]):  # every phase, e.g. 1SD's
        # floating_modes (its eigen-solve), so that the phases add up to t_total
        row[f"t_{ph}"] = s["timings"].get(ph, 0.0)
    if "steps" in s and s["steps"] and "lemke_pivots" in s["steps"][-1]:
        row["lemke_pivots"] = sum(st["lemke_pivots"] for st in s["steps"])
        row["lcp_size"] = s["steps"][-1]["lcp_size"]
    ref = s.get("reference", {})
    for path, name in columns:
        v = ref
        for key in path:
            v = v.get(key, {}) if isinstance(v, dict) else {}
        row[f"err_{name}"] = float(v) if isinstance(v, int | float) else math.nan
    floor = ref.get("hertz", {}).get("pressure_l2_interp_floor")
    if floor is not None:  # the interpolated L2's own floor at this pair spacing
        row["floor_pressure_l2_interp"] = floor
    return row


def finish_study(cfg: Config, out: Path, rows: list[dict], profiles: dict, ref_label: str,
                 reference_mode: str, quiet: bool, failures: list[str] | None = None,
                 plots: bool = True, timing: str = "") -> None:
    """Rank 0, after every run: the ref_* errors (Richardson limits or the finest level),
    the energy bracket, study.csv, the tables (printed unless quiet; with the failed runs
    and why, `failures`, which have no row; `timing`: the line on how t_total is counted)
    and, if `plots`, the plots. Also after each
    completed run without plots (milliseconds), so that an interrupt at any moment leaves
    the tables of the runs that completed."""
    limits = method_limits(rows, profiles) if reference_mode == "richardson" else []
    scalars = reference_scalars(limits, ref_label)
    missing = bool(limits) and scalars is None
    limits = [] if missing else limits
    note = add_reference_errors(rows, profiles, ref_label, scalars) + (
        f" (Richardson needs three consecutive levels of {ref_label})" if missing else "")
    bracket = energy_bracket(rows)
    write_csv(out / "study.csv", rows)
    if bracket:
        write_csv(out / "energy_bracket.csv", bracket)
    marks = order_marks(rows, limits, ref_label, extrapolated=scalars is not None)
    table = write_tables(rows, bracket, out, note, marks, timing)
    if limits:
        add_limit_spread(limits, ref_label)
        write_csv(out / "richardson.csv", limits)
        table += tables(limits, order_summary(rows, marks=marks))
    if failures:
        table += "\nfailed runs (no row in study.csv; see their summary.json)\n\n" + "".join(
            f"- {f.splitlines()[0]}\n" for f in failures)
    if limits or failures:
        atomic_write_bytes(out / "study_tables.md", table.encode())
    if not quiet:
        print(table, flush=True)
    if not plots:
        return
    floors = {f"ref_{r['quantity']}": r["uncertainty_rel"] for r in limits
              if r["method"] == ref_label}
    plot_study(rows, out, title=f"{cfg.path.stem} ({cfg.reference['type']})", note=note,
               floors=floors, constructed=marks)
    if bracket:
        plot_bracket(bracket, out)


def write_csv(path: Path, rows: list[dict]) -> None:
    """The rows as CSV (columns: every key, in the order first seen), through a rename."""
    tmp = path.with_suffix(".csv.tmp")
    with open(tmp, "w", newline="") as fh:
        fh.write(csv_text(rows))
    tmp.replace(path)


def csv_text(rows: list[dict]) -> str:
    """What `write_csv` writes."""
    buf = io.StringIO(newline="")
    w = csv.DictWriter(buf, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
    w.writeheader()
    w.writerows(rows)
    return buf.getvalue()


def plot_study(rows: list[dict], out: Path, title: str = "", note: str = "",
               floors: dict[str, float] | None = None,
               constructed: dict[tuple[str, str], set[int] | dict[int, str]] | None = None
               ) -> list[Path]:
    """error_vs_dofs.png, error_vs_time.png (closed-form errors err_* and errors against
    the model reference ref_*, one panel each) and energy_vs_sd.png in OUT; floors
    {column: relative uncertainty of the reference} are drawn as dotted lines;
    constructed: the orders the legend's "last order" skips (`order_marks`, see
    `_error_panel`)."""
    plt = pyplot()

    methods = list(dict.fromkeys(r["method"] for r in rows))
    errs = [k for k in dict.fromkeys(k for r in rows for k in r)
            if k.startswith(("err_", "ref_"))]
    paths = []
    for xkey, xlabel, fname in (("n_dofs", "DOFs", "error_vs_dofs.png"),
                                ("t_total", "wall time [s]", "error_vs_time.png")):
        ncol = min(4, len(errs))
        nrow = -(-len(errs) // ncol)
        fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.6 * nrow), squeeze=False)
        for ax in axes.ravel()[len(errs):]:
            ax.axis("off")
        for ax, ek in zip(axes.ravel(), errs, strict=False):
            _error_panel(ax, rows, methods, ek, xkey, xlabel, floors, constructed)
        fig.suptitle(f"{title}; {note}" if note else title, fontsize=10)
        fig.tight_layout()
        fig.savefig(out / fname, dpi=100)
        plt.close(fig)
        paths.append(out / fname)
    paths.append(_plot_energy_vs_sd(rows, methods, out))
    return paths


def _error_panel(ax: Any, rows: list[dict], methods: list[str], ek: str, xkey: str, xlabel: str,
                 floors: dict[str, float] | None,
                 constructed: dict[tuple[str, str], set[int] | dict[int, str]] | None = None
                 ) -> None:
    """One log-log panel of plot_study: column ek against xkey ("n_dofs": the legend
    gives the fitted rate and the last observed order, not one of the levels in
    `constructed`, e.g. the `order_marks` {level: mark}; the rate leaves out the levels
    marked "=" and the errors at most floors[ek]), one line per method, and the
    reference's uncertainty floors[ek] dotted if > 0."""
    import matplotlib.ticker

    for m in methods:
        rr = [r for r in rows if r["method"] == m]
        x = np.array([r[xkey] for r in rr], dtype=float)
        y = np.array([r.get(ek, math.nan) for r in rr], dtype=float)
        lab = m
        if xkey == "n_dofs":
            fixed = (constructed or {}).get((m, ek), set())
            orders = [r.get(f"order_{ek}", math.nan) if r["level"] not in fixed else math.nan
                      for r in rr]
            last = next((o for o in reversed(orders) if math.isfinite(o)), math.nan)
            # the fit leaves out errors that are no error against a finer solution ("="
            # marks of order_marks) or within the reference's uncertainty (floors)
            kinds = fixed if isinstance(fixed, dict) else {}
            fit = np.array([kinds.get(r["level"]) != "=" for r in rr], dtype=bool)
            fit &= ~(y <= (floors or {}).get(ek, 0.0))
            lv = np.array([r["level"] for r in rr], dtype=float)
            lab += (f" (rate {_figure(fitted_rate(lv[fit], y[fit]))}, "
                    f"last order {_figure(last)})")
        ax.loglog(x, y, "o-", label=lab, ms=3)
    if not any(np.isfinite(line.get_ydata()).any() for line in ax.lines):
        ax.text(0.5, 0.5, "no finite error in any run\n(e.g. a reference value of 0)",
                ha="center", va="center", transform=ax.transAxes, fontsize=8)
    if (floors or {}).get(ek, 0) > 0:
        ax.axhline(floors[ek], color="grey", ls=":", lw=1,
                   label="uncertainty of the Richardson limit")
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel(xlabel)
    ax.set_ylabel("relative error")
    ax.set_title(("vs closed form: " if ek.startswith("err_") else "vs reference: ")
                 + ek[4:], fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)


def _figure(v: float) -> str:
    """A legend's rate or order: two decimals, or "-" when there is none (NaN)."""
    return f"{v:.2f}" if math.isfinite(v) else "-"


def energy_title(rows: list[dict]) -> str:
    """The title of energy_vs_sd.png: which of 1SD and FEM-Q4 is the upper bound at every
    level that ran both (with loads prescribed 1SD, with displacements prescribed FEM-Q4),
    else no claim."""
    pairs = [(by["1SD"]["strain_energy"], by["FEM-Q4"]["strain_energy"])
             for level in {r["level"] for r in rows}
             for by in [{r["method"]: r for r in rows if r["level"] == level}]
             if "1SD" in by and "FEM-Q4" in by]
    if pairs and all(u1 >= uq for u1, uq in pairs):
        return "energy bounds: 1SD upper, FEM-Q4 lower"
    if pairs and all(u1 <= uq for u1, uq in pairs):
        return "energy bounds: FEM-Q4 upper, 1SD lower"
    return "strain energy against smoothing domains"


def sd_series(by_method: dict[str, dict], methods: list[str]) -> tuple[list[int], list[float]]:
    """(smoothing domains, strain energies) of one level's CS-FEM runs (`by_method`: label
    -> row), in increasing SD count whatever the order of --methods (in that order,
    `--methods 16,1,4` drew a line 16 -> 1 -> 4 that doubled back)."""
    sds = sorted((m for m in methods if m.endswith("SD") and m in by_method),
                 key=lambda m: int(m[:-2]))
    return [int(m[:-2]) for m in sds], [by_method[m]["strain_energy"] for m in sds]


def _plot_energy_vs_sd(rows: list[dict], methods: list[str], out: Path) -> Path:
    """OUT/energy_vs_sd.png: strain energy against the smoothing domains per element, one
    line per level, FEM-Q4 dashed; returns its path."""
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(5, 3.8))
    for level in sorted({r["level"] for r in rows}):
        rr = {r["method"]: r for r in rows if r["level"] == level}
        xs, ys = sd_series(rr, methods)
        line = ax.semilogx(xs, ys, "o-", label=f"level {level}", base=2)[0]
        if "FEM-Q4" in rr:
            ax.axhline(rr["FEM-Q4"]["strain_energy"], color=line.get_color(), ls="--", lw=0.8)
    ax.set_xlabel("smoothing domains per element (dashed: FEM-Q4)")
    ax.set_ylabel("strain energy")
    ax.set_title(energy_title(rows))
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "energy_vs_sd.png", dpi=100)
    plt.close(fig)
    return out / "energy_vs_sd.png"
