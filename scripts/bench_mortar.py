"""Verification table: node-to-segment against mortar (and, on request, mortar-smooth or
mortar-standard) on the same meshes, both ways round.

One JSON line per run: patch test (max |p - 10| / 10), Hertz (interpolated L2 of p at
a/10 ... a/80), Cattaneo (stick edges, L2 of q), multibody `indent` (largest deviation of
p from a local quadratic fit, relative to max p, over all closed pairs and two pairs in
from each end; max p), frictionless Cattaneo (where it stops).

    .venv/bin/python scripts/bench_mortar.py [--only patch hertz cattaneo multibody mu0
        family] [--hertz-sizes 0.5 0.25 0.125 0.0625] [--discretisations mortar]
        [--set KEY=VALUE ...] [--block2-sizes 0.08 0.02] [--plot PNG]

`--set` is passed to every run (for example a mesh option); the Hertz rows also carry the
peak and half-width errors, the element count, the mesh quality and the meshing time.

`family` (not in the default list): Cattaneo as a/R -> 0 (see `family`).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
from app_runner import ENV, ROOT

sys.path.insert(0, str(ROOT))
from app.contact.resolution import interior_deviation  # noqa: E402
from app.contact.smoothness import local_fit_deviation  # noqa: E402
from app.output.read import last_step_file, read_pairs  # noqa: E402

DISCS = ("node-to-segment", "mortar", "mortar-smooth", "mortar-standard",
         "mortar-coarse-slave")
SIDES = {  # config: (interface, default slave, default master)
    "patch": ("interface", "upper_bottom", "lower_top"),
    "hertz": ("contact", "cyl_arc", "block_top"),
    "cattaneo": ("contact", "cyl_arc", "block_top"),
    "multibody": ("indent", "cyl_arc", "block2_top"),
}


def run(config: str, disc: str, swapped: bool, extra: list[str],
        file: str | None = None) -> tuple[dict, dict | None]:
    """(summary or {"error"}, last step's contact arrays of the interface) of one run
    (`file`: the config's name in configs/ when not `config`, e.g. hertz_patch)."""
    itf, slave, master = SIDES[config]
    if swapped:
        slave, master = master, slave
    args = ["--set", f'interface.{itf}.discretisation="{disc}"',
            "--set", f'interface.{itf}.slave="{slave}"',
            "--set", f'interface.{itf}.master="{master}"', *extra]
    out = Path(tempfile.mkdtemp(prefix="mortar_bench_"))
    try:
        t0 = time.perf_counter()
        res = subprocess.run([sys.executable, "-m", "app", "run", f"configs/{file or config}.toml",
                              "--out", str(out), "--quiet", *args], cwd=ROOT, env=ENV,
                             capture_output=True, text=True)
        wall = time.perf_counter() - t0
        s = json.loads((out / "summary.json").read_text()) if (out / "summary.json").exists() \
            else {}
        s["wall_seconds"] = wall
        if res.returncode:
            s["error"] = res.stderr.strip()[-300:]
        last = last_step_file(out)
        if last is None:
            return s, None
        k = 2 if config == "multibody" else 0  # `indent` is the third [[interface]]
        return s, read_pairs(last, k)
    finally:
        shutil.rmtree(out, ignore_errors=True)


def family(k: float, refines: tuple[float, ...]) -> list[dict]:
    """Cattaneo with a/R -> 0: `cattaneo.toml` with the approach uy divided by k, the
    contact refinement size divided by sqrt(k) x refine and its flat zone by sqrt(k)
    (a/20 x refine at k = 1), and Q = 0.1 P (Q / (mu P) = 0.5), P measured by a first run
    without Q. One row per refine."""
    uy = -0.018788 / k
    base = ["--set", f"support.1.uy={uy}", "--set", f"mesh.refine.0.flat={0.15 / k**0.5}"]
    s, _ = run("cattaneo", "mortar", False, [*base, "--set", "load.0.total_force=[0.0,0.0]",
                                              "--set", f"mesh.refine.0.size={0.005 / k**0.5}"])
    p = s["reference"]["hertz"]["P"]
    rows = []
    for refine in refines:
        s, c = run("cattaneo", "mortar", False, [
            *base, "--set", f"load.0.total_force=[{0.1 * p},0.0]",
            "--set", f"mesh.refine.0.size={0.005 / k**0.5 / refine}"])
        ca = s.get("reference", {}).get("cattaneo", {})
        rows.append({"case": "cattaneo_family", "k": k, "refine": refine, "uy": uy,
                     "Q": 0.1 * p, "error": s.get("error"), "n_dofs": s.get("n_dofs"),
                     "a": ca.get("a_hertz"), "element": 0.005 / k**0.5 / refine,
                     "Q_over_muP": ca.get("Q_over_muP"), "stick_edges": ca.get("stick_edges"),
                     "stick_half_width_exact": ca.get("stick_half_width_exact"),
                     "q_l2_interp": ca.get("traction_l2_interp_rel_error")})
    return rows


def emit(row: dict) -> None:
    print(json.dumps(row), flush=True)


def _arguments() -> argparse.Namespace:
    """The command line (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", default=["patch", "hertz", "cattaneo", "multibody",
                                                   "mu0"],
                    choices=["patch", "hertz", "cattaneo", "multibody", "mu0", "family"],
                    help="cases to run (an unknown one is an error; before: nothing, exit 0)")
    ap.add_argument("--hertz-sizes", type=float, nargs="+", default=[0.5, 0.25, 0.125, 0.0625])
    ap.add_argument("--discretisations", nargs="+", choices=DISCS, default=list(DISCS[:2]))
    ap.add_argument("--block2-sizes", type=float, nargs="+", default=[0.08, 0.02],
                    help="element sizes of block2 in the multibody rows (0.08: as shipped)")
    ap.add_argument("--hertz-config", default="hertz",
                    help="config of the Hertz rows in configs/ (e.g. hertz_patch)")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                    help="config override passed to every run (repeatable)")
    ap.add_argument("--plot", help="PNG of the multibody rows' p(x), a panel per block2 size")
    return ap.parse_args()


def main() -> None:
    a = _arguments()
    extra = [x for kv in a.sets for x in ("--set", kv)]
    if "family" in a.only:
        for k in (1, 4, 16, 64, 256):
            for row in family(k, (1, 2)):
                emit(row)
    for disc in a.discretisations:
        for swapped in (False, True):
            base = {"discretisation": disc, "swapped": swapped} | ({"set": a.sets} if a.sets
                                                                   else {})
            for case, rows in CASES.items():
                if case in a.only:
                    for row in rows(disc, swapped, extra, a):
                        emit(base | row)
    if a.plot and PROFILES:
        plot_profiles(a.plot)


PROFILES: dict[tuple[str, bool, float], tuple[np.ndarray, np.ndarray, float]] = {}
"""(discretisation, swapped, block2 size) -> closed pairs' x, p and median slave element
length of the multibody rows."""


def plot_profiles(path: str) -> None:
    """p(x) of the multibody `indent` rows: one panel per block2 size, a line per run."""
    from app.plotting import pyplot

    plt = pyplot()
    sizes = sorted({k[2] for k in PROFILES}, reverse=True)
    fig, axes = plt.subplots(1, len(sizes), figsize=(4.2 * len(sizes), 3.6), sharey=True,
                             squeeze=False)
    for ax, size in zip(axes[0], sizes, strict=True):
        for (disc, swapped, s), (x, p, h) in PROFILES.items():
            if s == size:
                side = "block2" if swapped else "arc"
                ax.plot(x, p, ".-", label=f"{disc}, {side} as slave ({h:.3g})")
        ax.set_title(f"block2 elements {size:g}")
        ax.set_xlabel("x")
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("p, multibody indent, last step")
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def _patch_rows(disc: str, swapped: bool, extra: list[str],
                a: argparse.Namespace) -> Iterator[dict]:
    """Patch test: the largest relative deviation of p from 10."""
    s, c = run("patch", disc, swapped, extra)
    yield {"case": "patch", "error": s.get("error"),
           "max_rel_dev": float(np.abs(c["p"] - 10).max() / 10)}


def _hertz_rows(disc: str, swapped: bool, extra: list[str],
                a: argparse.Namespace) -> Iterator[dict]:
    """Hertz at every --hertz-sizes: pressure errors, sizes, mesh quality, seconds."""
    for h in a.hertz_sizes:
        s, c = run("hertz", disc, swapped, ["--mesh-size", str(h), *extra], a.hertz_config)
        hz = s.get("reference", {}).get("hertz", {})
        q = s.get("mesh_quality", {})
        yield {"case": "hertz", "config": a.hertz_config, "mesh_size": h,
               "error": s.get("error"),
               "n_dofs": s.get("n_dofs"), "n_elements": s.get("n_elements"),
               "wall_s": round(s["wall_seconds"], 2),
               "min_angle": q.get("min_corner_angle_deg"),
               "max_angle": q.get("max_corner_angle_deg"),
               "max_aspect": q.get("max_aspect_ratio"),
               "p_max_err": hz.get("p_max_rel_error"),
               "half_width_err": hz.get("half_width_rel_error"),
               "p_l2_interp_floor": hz.get("pressure_l2_interp_floor"),
               "element": float(np.median(c["length"][c["p"] > 0])),
               "seconds": {k: round(v, 3) for k, v in s.get("timings", {}).items()},
               "p_l2_interp": hz.get("pressure_l2_interp_rel_error"),
               "p_l2": hz.get("pressure_l2_rel_error")}


def _cattaneo_rows(disc: str, swapped: bool, extra: list[str],
                   a: argparse.Namespace) -> Iterator[dict]:
    """Cattaneo: stick edges and the L2 errors of q."""
    s, c = run("cattaneo", disc, swapped, extra)
    ca = s.get("reference", {}).get("cattaneo", {})
    yield {"case": "cattaneo", "error": s.get("error"), "stick_edges": ca.get("stick_edges"),
           "q_l2_interp": ca.get("traction_l2_interp_rel_error"),
           "q_l2": ca.get("traction_l2_rel_error")}


def _multibody_rows(disc: str, swapped: bool, extra: list[str],
                    a: argparse.Namespace) -> Iterator[dict]:
    """Multibody `indent` at every --block2-sizes: the largest deviation of p from a
    local quadratic fit."""
    for block2 in a.block2_sizes:  # 0.08 as shipped, 0.02 about the arc's
        b2 = ["--set", f"body.block2.size={block2}"]
        s, c = run("multibody", disc, swapped, [*b2, *extra])
        on = c["p"] > 0
        x, p = c["x"][on], c["p"][on]  # (read_pairs sorts by x)
        PROFILES[(disc, swapped, block2)] = (x, p, float(np.median(c["length"][on])))
        yield {"case": "multibody", "block2_size": block2, "error": s.get("error"),
               "n_in_contact": int(on.sum()),
               "max_fit_deviation": float(local_fit_deviation(x, p).max(initial=0.0)),
               "inner_fit_deviation": interior_deviation(np.column_stack([x, 0 * x]), p),
               "max_p": float(c["p"].max(initial=0.0))}


def _mu0_rows(disc: str, swapped: bool, extra: list[str],
              a: argparse.Namespace) -> Iterator[dict]:
    """Frictionless Cattaneo: the step where it stops."""
    s, c = run("cattaneo", disc, swapped, ["--set", "interface.contact.mu=0.0", *extra])
    yield {"case": "cattaneo_mu0", "failed_step": s.get("failed_step"),
           "steps_written": len(s.get("steps", [])), "error": (s.get("error") or "")[:120]}


CASES: dict[str, Callable[[str, bool, list[str], argparse.Namespace], Iterator[dict]]] = {
    "patch": _patch_rows, "hertz": _hertz_rows, "cattaneo": _cattaneo_rows,
    "multibody": _multibody_rows, "mu0": _mu0_rows}
"""The rows of each --only case for one (discretisation, swapped), in the output order."""


if __name__ == "__main__":
    main()
