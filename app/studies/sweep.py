"""Parameter studies: `python -m app study CONFIG --sweep KEY=V1,V2,... [--sweep ...]`.

Every combination of the swept values runs once (KEY is a config path as in `--set`).
Writes OUT/sweep.csv (one row per combination: the contact's response at the report step,
peaks over the steps, dissipation and debonding steps, per interface), OUT/sweep_steps.csv
(one row per combination, step and interface) and OUT/sweep_<key>.png plots.
"""

from __future__ import annotations

import itertools
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from petsc4py import PETSc

from app import exit_sync, hard_stop
from app.assembly.loads import check_groups_before_meshing
from app.config import _override_value, load_config
from app.errors import InputError, SolveError
from app.output.batch_guard import BatchGuard
from app.output.status import step_writing, stop_status
from app.plotting import pyplot
from app.run import RunOptions, run
from app.studies.convergence import csv_text, write_csv
from app.studies.missing_runs import missing_combinations

ZONES = ("contact", "stick", "slip", "open", "bonded")


def split_values(text: str) -> list[str]:
    """'0.1,0.2,[1, 2]' -> ['0.1', '0.2', '[1, 2]']: commas inside brackets/quotes kept."""
    out, depth, cur, quote = [], 0, "", None
    for ch in text:
        if quote:
            quote = None if ch == quote else quote
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            out.append(cur.strip())
            cur = ""
            continue
        cur += ch
    out.append(cur.strip())
    return [v for v in out if v]


def parse_sweeps(items: list[str]) -> list[tuple[str, list[str]]]:
    """['interface.bond.c=1,2'] -> [('interface.bond.c', ['1', '2'])]; InputError if bad
    or if a key is swept twice (its later values would silently replace the earlier)."""
    out = []
    for item in items:
        key, sep, vals = item.partition("=")
        values = split_values(vals)
        if not sep or not key.strip() or not values:
            raise InputError(f"--sweep '{item}': use KEY=V1,V2,... (e.g. "
                             "interface.contact.mu=0.1,0.2,0.3)")
        if key.strip() in dict(out):
            raise InputError(f"--sweep '{item}': {key.strip()} is swept twice; give all its "
                             "values in one --sweep")
        _check_distinct(item, values)
        out.append((key.strip(), values))
    return out


def _check_distinct(item: str, values: list[str]) -> None:
    """InputError when two values of one --sweep are the same value (`0.1,0.1`, `1,1.0`,
    `0.1,1e-1`): before, the combination ran twice and sweep.csv had two identical rows."""
    seen: dict = {}
    for text in values:
        v = _value(text)  # 1 == 1.0: one value
        if v in seen:
            same = (f"the value {text} is given twice" if seen[v] == text else
                    f"{seen[v]} and {text} are the same value")
            raise InputError(f"--sweep '{item}': {same} (each combination runs once); "
                             "give each value once")
        seen[v] = text


def report_step(at_step: int, n_steps: int) -> int:
    """The 1-based step that --at-step names in a run of n_steps steps (at_step <= 0 counts
    back from the last); InputError when the run has no such step."""
    k = at_step if at_step > 0 else n_steps + at_step
    if not 1 <= k <= n_steps:
        raise InputError(f"--at-step {at_step}: the run has {n_steps} steps (use 1..{n_steps}, "
                         f"or 0..{1 - n_steps} counting back from the last)")
    return k


def step_rows(summary: dict) -> list[dict]:
    """Per step and interface: resultants, max p, zone lengths, debonded pairs."""
    rows = []
    for st in summary.get("steps", []):
        for name, it in (st.get("interfaces") or {}).items():
            sl = it.get("state_lengths", {})
            rows.append({
                "step": st["step"], "interface": name,
                "normal_force": it["normal_force"], "tangential_force": it["tangential_force"],
                "max_pressure": it["max_pressure"],
                "contact_length": it.get("contact_length", math.nan),
                "stick_length": sl.get("stick", math.nan),
                "slip_length": sl.get("slip+", 0.0) + sl.get("slip-", 0.0),
                "open_length": sl.get("open", math.nan),
                "bonded_length": sl.get("bonded", math.nan),
                "debonded_pairs": it.get("debonded_pairs", 0), "n_pairs": it["n_pairs"],
                "bond_strength_force": it.get("bond_strength_force", 0.0),
                # the interface's own (the step's total is every interface's sum)
                "dissipation": it.get("dissipation", st.get("dissipation", 0.0)),
            })
    return rows


def summarize(steps: list[dict], at_step: int) -> dict:
    """One interface's figures: values at `at_step` (1-based, <= 0 counts from the end),
    peaks over the steps, total dissipation, debonding start and completion steps."""
    if not steps:
        return {}
    k = at_step - 1 if at_step > 0 else len(steps) + at_step - 1
    row = steps[min(max(k, 0), len(steps) - 1)]
    out = {"step": row["step"]}  # the step the figures below are at (--at-step)
    out |= {f"{q}": row[q] for q in ("normal_force", "tangential_force", "max_pressure")}
    out |= {f"{z}_length": row[f"{z}_length"] for z in ZONES}
    out["peak_normal_force"] = max(abs(s["normal_force"]) for s in steps)
    out["peak_tangential_force"] = max(abs(s["tangential_force"]) for s in steps)
    out["peak_max_pressure"] = max(s["max_pressure"] for s in steps)
    out["dissipation"] = float(sum(s["dissipation"] for s in steps))
    started = [s["step"] for s in steps if s["debonded_pairs"] > 0]
    done = [s["step"] for s in steps if s["debonded_pairs"] >= s["n_pairs"] > 0]
    out["debond_start_step"] = started[0] if started else math.nan
    out["debond_complete_step"] = done[0] if done else math.nan
    return out


def run_sweep(config: Path, sets: list[str], sweeps: list[tuple[str, list[str]]], out: Path,
              opts: dict, at_step: int = 0, quiet: bool = False) -> list[dict]:
    """Run every combination; returns the sweep.csv rows. Raises SolveError if all fail."""
    keys = [k for k, _ in sweeps]
    sweep = Sweep(config, sets, keys, list(itertools.product(*[v for _, v in sweeps])),
                  Path(out), opts, at_step, quiet)
    in_c = sweep.hard_stop_texts  # (a bound method: removed by equality)
    with BatchGuard(lambda: _write_completed(sweep)):
        hard_stop.add_extra(in_c)  # a signal inside a run's long PETSc call
        try:
            for i, combo in enumerate(sweep.combos):
                _run_combination(sweep, i, combo)
        finally:
            hard_stop.remove_extra(in_c)
    if len(sweep.failed) == len(sweep.combos):
        raise SolveError(f"every run of the sweep failed (first: {sweep.failed[0]})")
    if PETSc.COMM_WORLD.getRank() == 0:
        write_csv(sweep.out / "sweep.csv", sweep.rows)
        plot_sweep(sweep.rows, keys, sweep.out, at_step)
    return sweep.rows


@dataclass
class Sweep:
    """One parameter sweep: the config, its `--set` overrides, the swept keys and their
    combinations, the runs' options (`opts`: RunOptions fields) and, as it goes, the
    sweep.csv rows, the sweep_steps.csv rows and the failed runs' messages."""

    config: Path
    sets: list[str]
    keys: list[str]
    combos: list[tuple[str, ...]]
    out: Path
    opts: dict
    at_step: int
    quiet: bool
    rows: list[dict] = field(default_factory=list)
    all_steps: list[dict] = field(default_factory=list)
    failed: list[str] = field(default_factory=list)
    t0: float = field(default_factory=time.perf_counter)  # progress lines' clock
    started: float = field(default_factory=lambda: time.time() - 0.1)  # (file times: coarse)
    current: int = -1  # the index of the run in progress
    _stop_texts: tuple = ((), (None, b"", ""))  # hard_stop_texts' (key, texts)

    def hard_stop_texts(self, name: str, line: str) -> tuple[Path | None, bytes, str]:
        """What app/_hard_stop.c writes after the run's and the study's summary when a
        signal stops the run in progress inside a long PETSc call (rank 0 of several): what
        `_write_completed` writes there (sweep.csv with a row for each run that did not
        complete, this one `interrupted`; no plots) and its line. Built once per run (each
        long call arms it)."""
        key = (len(self.rows), self.current)
        if self._stop_texts[0] != key:
            if not self.rows:
                texts = (None, b"", _no_run_line(self.out) + "\n")
            else:
                missing = missing_combinations(self.out, self.keys, self.combos, self.rows,
                                               _value, since=self.started,
                                               stopped=self.current)
                texts = (self.out / "sweep.csv", csv_text(self.rows + missing).encode(),
                         _interrupted_line(self, len(missing), False) + "\n")
            self._stop_texts = (key, texts)
        return self._stop_texts[1]


def _run_combination(sweep: Sweep, i: int, combo: tuple[str, ...]) -> None:
    """Run combination i (its folder OUT/run_<i>) and record its rows, or its failure."""
    rank = PETSc.COMM_WORLD.getRank()
    sweep.current = i
    pairs = list(zip(sweep.keys, combo, strict=True))
    tag = f"run {i + 1}/{len(sweep.combos)} " + " ".join(f"{k}={v}" for k, v in pairs)
    overrides = [*sweep.sets, *(f"{k}={v}" for k, v in pairs)]
    ro = RunOptions(out=sweep.out / f"run_{i:03d}", quiet=sweep.quiet, progress_prefix=tag,
                    overrides=overrides, **sweep.opts)
    params = {k: _value(v) for k, v in pairs}
    s = _try_combination(sweep, ro, params)
    if s is None:
        return
    step_writing(True)  # an interrupt waits for the rows to be recorded
    try:
        _record_run(s, params, sweep.at_step, sweep.rows, sweep.all_steps,
                    sweep.out if rank == 0 else None)
    finally:
        step_writing(False)
    if rank == 0 and not sweep.quiet:
        print(f"[{time.perf_counter() - sweep.t0:8.2f} s] {tag}: done", file=sys.stderr,
              flush=True)


def _try_combination(sweep: Sweep, ro: RunOptions, params: dict) -> dict | None:
    """The run's summary, or None when its config or run failed: a combination the config
    checks reject (e.g. c < mu a) fails alone, with a `failed` row and its error."""
    try:
        cfg = load_config(sweep.config, ro.overrides)
        report_step(sweep.at_step, cfg.n_steps)
        check_groups_before_meshing(cfg)  # this run's names (app/cli.py checks no base's)
        return run(cfg, ro)
    except (InputError, SolveError) as exc:
        if not exit_sync.failed_together():
            raise  # this rank failed alone: the others wait in the run (app/exit_sync.py)
        sweep.failed.append(str(exc))
        if PETSc.COMM_WORLD.getRank() == 0:
            print(f"[{time.perf_counter() - sweep.t0:8.2f} s] {ro.progress_prefix}: failed: "
                  f"{exc}", file=sys.stderr, flush=True)
        sweep.rows.append({**params, "status": "failed", "error": str(exc).splitlines()[0]})
        return None


def _write_completed(sweep: Sweep) -> str:
    """On SIGINT / SIGTERM (rank 0): sweep.csv with a row for each run that did not
    complete and the plots of those that did; returns the one-line account."""
    out = sweep.out
    if not sweep.rows:
        return _no_run_line(out)
    plots = PETSc.COMM_WORLD.getSize() == 1  # several ranks: mpiexec kills in 1 s
    missing = missing_combinations(out, sweep.keys, sweep.combos, sweep.rows, _value,
                                   since=sweep.started)
    write_csv(out / "sweep.csv", sweep.rows + missing)  # with a row for each missing run
    if plots:
        plot_sweep([dict(r) for r in sweep.rows], sweep.keys, out, sweep.at_step)
    return _interrupted_line(sweep, len(missing), plots, stop_status())


def _no_run_line(out: Path) -> str:
    """The `sweep:` line of a sweep stopped before a run completed (no sweep.csv)."""
    return f"sweep: no run completed in {out}"


def _interrupted_line(sweep: Sweep, n_missing: int, plots: bool,
                      state: str = "interrupted") -> str:
    """The `sweep:` line of an interrupted sweep with rows (state `failed`: ended by
    mpiexec's answer to a rank that failed alone, app/output/status.py `stop_status`)."""
    return (f"sweep: {state}; its {len(sweep.rows)} rows are in sweep.csv" +
            (" and the plots" if plots else " (no plots on several ranks)") +
            f", in {sweep.out}, with a row for each of the {n_missing} runs that did not "
            "complete")


def _record_run(s: dict, params: dict, at_step: int, rows: list[dict],
                all_steps: list[dict], out: Path | None) -> None:
    """Append a completed run's rows (one per interface) and step rows; rewrite sweep.csv
    and sweep_steps.csv into `out` (rank 0; None elsewhere)."""
    steps = step_rows(s)
    all_steps.extend({**params, **r} for r in steps)
    # a scene without [[interface]]: one row all the same (before, none: its completed
    # runs were missing from sweep.csv, and an interrupted sweep counted them not run)
    for name in dict.fromkeys(r["interface"] for r in steps) or [""]:
        mine = [r for r in steps if r["interface"] == name]
        rows.append({**params, "status": "completed", "interface": name,
                     "n_dofs": s["n_dofs"], "t_total": s["timings"]["total"],
                     **summarize(mine, at_step)})
    if out is not None:
        write_csv(out / "sweep.csv", rows)
        write_csv(out / "sweep_steps.csv", all_steps)


def _value(text: str):
    """A TOML scalar as the number it is, with its TOML type (`1` -> int 1, as the run
    reads it: before, float() made `analysis.sd=1` a `1.0` in sweep.csv and the legends;
    `0.3`, `1e3`, `inf` -> float), a TOML string as its text (`"cs-fem"` -> cs-fem:
    before, sweep.csv and the legends kept the quotes), else the text as given (a bool,
    an array, a table: the text the user wrote)."""
    value = _override_value(text.strip())
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return value
    return value if isinstance(value, str) else text


PANELS = [
    ("resultants", ("normal_force", "tangential_force", "peak_tangential_force")),
    ("max pressure", ("max_pressure", "peak_max_pressure")),
    ("zone lengths", tuple(f"{z}_length" for z in ZONES)),
    ("dissipation", ("dissipation",)),
    ("debonding step", ("debond_start_step", "debond_complete_step")),
]


STYLES = ("-", "--", ":", "-.")
MARKERS = ("o", "x", "+", "^", "s")  # per quantity: coinciding curves stay told apart


def report_label(rows: list[dict], at_step: int) -> str:
    """Which step the plots' figures are at: "the last step", "step N" (for --at-step < 0
    the step it names when all rows agree, before: "step -3"), or "K steps before the last"."""
    if at_step >= 0:
        return "the last step" if at_step == 0 else f"step {at_step}"
    steps = {r.get("step") for r in rows}
    if len(steps) == 1 and isinstance(step := steps.pop(), int):
        return f"step {step}"
    return f"{-at_step} steps before the last"


def plot_sweep(rows: list[dict], keys: list[str], out: Path, at_step: int = 0) -> list[Path]:
    """sweep_<key>.png per swept key: the contact's figures against the key's value; colour
    = quantity, line style = interface and combination of the other keys."""
    plt = pyplot()

    # (a run without interfaces has a row, and no contact figures to draw)
    ok = [r for r in rows if r.get("status") == "completed" and r.get("interface")]
    when = report_label(ok, at_step)
    paths = []
    for key in keys:
        if not ok or len({isinstance(r[key], str) for r in ok}) > 1:
            continue  # (values all numbers, int or float, or all text: then categorical)
        others = [k for k in keys if k != key]
        groups: dict[tuple, list[dict]] = {}
        for r in ok:
            groups.setdefault((r["interface"], *(r[k] for k in others)), []).append(r)
        fig, axes = plt.subplots(2, 3, figsize=(12, 6.4))
        for ax, (title, cols) in zip(axes.ravel(), PANELS, strict=False):
            _sweep_panel(ax, title, cols, list(groups.values()), key, when)
        _style_legend(axes.ravel()[-1], list(groups), others)
        fig.tight_layout()
        path = out / f"sweep_{key.replace('.', '_')}.png"
        fig.savefig(path, dpi=70)
        plt.close(fig)
        paths.append(path)
    return paths


def _size(i: int, n: int, first: float, last: float, step: float) -> float:
    """Line width or marker size [pt] of quantity i of n: from `first` down by `step` per
    quantity, thick first so that coinciding curves all show, the step shrunk so that the
    n-th is no smaller than `last` (before: 0.2 pt lines, 1 pt markers for the fifth
    quantity, the bonded length)."""
    return first - i * min(step, (first - last) / max(n - 1, 1))


def _sweep_panel(ax, title: str, cols: list[str], groups: list[list[dict]], key: str,
                 when: str) -> None:
    """One panel: the columns `cols` (colours) of every group (line styles) against key."""
    from matplotlib.lines import Line2D

    for j, rr in enumerate(groups):
        rr = sorted(rr, key=lambda r: r[key])
        x = [r[key] for r in rr]
        for i, c in enumerate(cols):
            y = np.array([r.get(c, math.nan) for r in rr], dtype=float)
            if not np.all(np.isnan(y)):
                ax.plot(x, y, marker=MARKERS[i % len(MARKERS)], ms=_size(i, len(cols), 7, 3, 1.5),
                        mfc="none", color=f"C{i}", ls=STYLES[j % len(STYLES)],
                        lw=_size(i, len(cols), 2.2, 0.8, 0.5))
    handles = [Line2D([], [], color=f"C{i}", marker=MARKERS[i % len(MARKERS)], mfc="none",
                      label=c.replace("_length", "").replace("_", " "))
               for i, c in enumerate(cols)]
    if ax.lines:
        ax.legend(handles=handles, fontsize=7)
    else:
        ax.text(0.5, 0.5, "none in any run", ha="center", transform=ax.transAxes)
    ax.set_xlabel(key)
    ax.set_title(title + ("" if title in ("dissipation", "debonding step")
                          else f" (at {when}; peaks over all steps)"
                          if "peak" in " ".join(cols) else f" (at {when})"), fontsize=9)
    ax.grid(True, alpha=0.3)


def _style_legend(ax, groups: list[tuple], others: list[str]) -> None:
    """The last panel: which line style is which interface and other keys' values."""
    from matplotlib.lines import Line2D

    ax.axis("off")
    ax.legend(handles=[Line2D([], [], color="k", ls=STYLES[j % len(STYLES)],
                              label=", ".join([f"interface {g[0]}"] + [
                                  f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}"
                                  for k, v in zip(others, g[1:], strict=True)]))
                       for j, g in enumerate(groups)], loc="center", fontsize=8,
              title="line style")
