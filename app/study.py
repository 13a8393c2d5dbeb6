"""Convergence studies: every method at every refinement level, timed and checked against
the scene's closed form. Writes study.csv and PNG plots (matplotlib, Agg).

Level l scales every element size of the config by base_scale * 2**-l (so each level
halves the element size near the contact); meshes are cached and reused across methods
and reruns.
"""

from __future__ import annotations

import csv
import math
import time
from pathlib import Path

import numpy as np
from petsc4py import PETSc

from app.config import Config
from app.discretisation.methods import BULK_METHODS
from app.errors import InputError, SolveError
from app.references import REFERENCES
from app.run import RunOptions, run

PHASES = ("mesh", "assembly", "factorization", "solve", "pair_search", "compliance", "lcp",
          "recovery", "output", "total")


def parse_methods(text: str) -> list[tuple[str, int]]:
    """'1,2,4,q4' -> [("cs-fem", 1), ("cs-fem", 2), ("cs-fem", 4), ("fem-q4", 4)].

    A bare number is a CS-FEM smoothing-domain count; other names come from the
    bulk-method registry (`BulkMethod.study_names`).
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
    return out


def label(method: str, sd: int) -> str:
    """The study's short label, e.g. "4SD" or "FEM-Q4"."""
    return BULK_METHODS[method].short(sd)


def run_study(cfg: Config, out: Path, levels: int, methods: list[tuple[str, int]],
              base_scale: float = 1.0, quiet: bool = False, first_level: int = 0) -> list[dict]:
    """Run every (level, method); returns the rows written to OUT/study.csv."""
    rank = PETSc.COMM_WORLD.getRank()
    if cfg.reference is None:
        raise InputError(f"{cfg.path}: a study needs a [reference] table with type one of "
                         f"{sorted(REFERENCES)}")
    columns = REFERENCES[cfg.reference["type"]].columns
    out = Path(out)
    cache = out / "mesh_cache"
    rows: list[dict] = []
    t0 = time.perf_counter()
    for level in range(first_level, first_level + levels):
        for method, sd in methods:
            tag = f"level {level}/{first_level + levels - 1} {label(method, sd)}"
            opts = RunOptions(out=out / f"L{level}_{label(method, sd)}", method=method, sd=sd,
                              mesh_scale=base_scale * 2.0**-level, quiet=quiet,
                              mesh_cache=cache, progress_prefix=tag)
            try:
                s = run(cfg, opts)
            except SolveError as exc:
                if rank == 0 and not quiet:
                    print(f"[{time.perf_counter() - t0:8.2f} s] {tag}: failed: {exc}")
                continue
            row = {"level": level, "method": label(method, sd), "n_dofs": s["n_dofs"],
                   "n_elements": s["n_elements"], "n_pairs": s.get("n_pairs", 0),
                   "ranks": s["ranks"], "strain_energy": s["strain_energy"]}
            for ph in PHASES:
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
            rows.append(row)
            if rank == 0:
                write_csv(out / "study.csv", rows)
                if not quiet:
                    errs = ", ".join(f"{k[4:]} {row[k]:.3e}" for k in row if k.startswith("err_"))
                    print(f"[{time.perf_counter() - t0:8.2f} s] {tag}: {row['n_dofs']} DOFs, "
                          f"{row['t_total']:.2f} s, {errs}", flush=True)
    if rank == 0 and rows:
        plot_study(rows, out, title=f"{cfg.path.stem} ({cfg.reference['type']})")
    return rows


def write_csv(path: Path, rows: list[dict]) -> None:
    keys = list(dict.fromkeys(k for r in rows for k in r))
    tmp = path.with_suffix(".csv.tmp")
    with open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    tmp.replace(path)


def fitted_rate(dofs: np.ndarray, err: np.ndarray) -> float:
    """Convergence rate in element size h ~ DOFs^-1/2: slope of log err vs log h."""
    ok = np.isfinite(err) & (err > 0)
    if ok.sum() < 2:
        return math.nan
    h = dofs[ok] ** -0.5
    return float(np.polyfit(np.log(h), np.log(err[ok]), 1)[0])


def plot_study(rows: list[dict], out: Path, title: str = "") -> list[Path]:
    """error_vs_dofs.png, error_vs_time.png and energy_vs_sd.png in OUT."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(dict.fromkeys(r["method"] for r in rows))
    errs = [k for k in rows[0] if k.startswith("err_")]
    paths = []
    for xkey, xlabel, fname in (("n_dofs", "DOFs", "error_vs_dofs.png"),
                                ("t_total", "wall time [s]", "error_vs_time.png")):
        fig, axes = plt.subplots(1, len(errs), figsize=(4.2 * len(errs), 3.8), squeeze=False)
        for ax, ek in zip(axes[0], errs, strict=True):
            for m in methods:
                rr = [r for r in rows if r["method"] == m]
                x = np.array([r[xkey] for r in rr], dtype=float)
                y = np.array([r[ek] for r in rr], dtype=float)
                lab = m
                if xkey == "n_dofs":
                    lab += f" (rate {fitted_rate(x, y):.2f})"
                ax.loglog(x, y, "o-", label=lab, ms=3)
            ax.set_xlabel(xlabel)
            ax.set_ylabel("relative error")
            ax.set_title(ek[4:])
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=7)
        fig.suptitle(title)
        fig.tight_layout()
        fig.savefig(out / fname, dpi=100)
        plt.close(fig)
        paths.append(out / fname)
    fig, ax = plt.subplots(figsize=(5, 3.8))
    sds = [m for m in methods if m.endswith("SD")]
    for level in sorted({r["level"] for r in rows}):
        rr = {r["method"]: r for r in rows if r["level"] == level}
        xs = [int(m[:-2]) for m in sds if m in rr]
        ys = [rr[m]["strain_energy"] for m in sds if m in rr]
        line = ax.semilogx(xs, ys, "o-", label=f"level {level}", base=2)[0]
        if "FEM-Q4" in rr:
            ax.axhline(rr["FEM-Q4"]["strain_energy"], color=line.get_color(), ls="--", lw=0.8)
    ax.set_xlabel("smoothing domains per element (dashed: FEM-Q4)")
    ax.set_ylabel("strain energy")
    ax.set_title("energy bounds: 1SD upper, FEM-Q4 lower")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "energy_vs_sd.png", dpi=100)
    plt.close(fig)
    paths.append(out / "energy_vs_sd.png")
    return paths
