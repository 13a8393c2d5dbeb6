"""Benchmark: how each phase grows with the mesh (DOFs) for a scene and its contact discretisations.

Runs `python -m app run CONFIG --refine N` for each refinement level N (every quad split into
four N times, so the DOFs grow about 4x a level) and each contact discretisation (set on every
interface), and prints one JSON line per run: DOFs, pairs, steps, the wall time seen from
outside the process, the run's `total`, the sum of its phases, the time outside any phase
(wall - total: the exit, and before the `launch` phase existed the interpreter, the
imports and PETSc's start), the peak
resident memory (MB, summed over ranks), the output's size (MB), with 10 steps or more the
median step seconds of the first and the last tenth of the steps and the mean Lemke pivots
after the first step, and the seconds of each phase. After the runs of a
discretisation, one line `"fit"` per phase gives the growth exponent b of t ~ DOFs^b
(least squares on the logs, and between the last two sizes); b > 1.15 flags a phase that
grows faster than the DOFs.

    .venv/bin/python scripts/bench_scale.py configs/hertz.toml --refine 0 1 2 3 \
        --discretisations node-to-segment mortar [--ranks 2] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np
from app_runner import ENV, ROOT, app_command

SMALL_S = 0.02
"""Phases shorter than this at the largest size are left out of the fits (timer noise)."""


def n_interfaces(config: Path) -> int:
    """Number of `[[interface]]` entries in the config file."""
    return len(tomllib.loads(config.read_text()).get("interface", []))


def run(config: Path, args: list[str], ranks: int) -> dict:
    """One run: its summary's figures and the wall seconds around the process."""
    out = Path(tempfile.mkdtemp(prefix="bench_scale_"))
    try:
        cmd = app_command(["run", str(config), "--out", str(out), "--quiet", *args], ranks)
        t0 = time.perf_counter()
        res = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        path = out / "summary.json"
        if not path.exists():
            return {"error": res.stderr.strip()[-300:]}
        s = json.loads(path.read_text())
        out_mb = sum(f.stat().st_size for f in out.iterdir()) / 2**20
    finally:
        shutil.rmtree(out, ignore_errors=True)
    t = s.get("timings", {})
    phases = {k: round(v, 4) for k, v in t.items() if k != "total"}
    total = t.get("total", float("nan"))
    mem = s.get("peak_memory_mb") or {}
    steps = s.get("steps") or []
    return {"status": s.get("status"), "n_dofs": s.get("n_dofs"), "n_pairs": s.get("n_pairs"),
            "n_steps": s.get("n_steps"), "wall_s": round(wall, 3), "total_s": round(total, 3),
            "phases_over_total": round(sum(phases.values()) / total, 4),
            "outside_s": round(wall - total, 3),
            "peak_mb": max(mem.values()) if mem else None,
            "output_mb": round(out_mb, 2), **step_figures(steps), "phases": phases}


def step_figures(steps: list[dict]) -> dict:
    """Over many steps: median step seconds of the first and the last tenth, and the mean
    Lemke pivots of the steps after the first (warm starts)."""
    if len(steps) < 10:
        return {}
    sec = [st.get("step_seconds", np.nan) for st in steps]
    k = max(1, len(sec) // 10)
    piv = [st.get("lemke_pivots", 0) or 0 for st in steps[1:]]
    return {"step_s_first": round(float(np.median(sec[:k])), 4),
            "step_s_last": round(float(np.median(sec[-k:])), 4),
            "pivots_mean": round(float(np.mean(piv)), 2)}


def fits(rows: list[dict]) -> dict[str, dict]:
    """Growth exponent of each phase (and the total) in the DOFs, from the rows' timings."""
    ok = [r for r in rows if r.get("n_dofs") and "phases" in r]
    if len(ok) < 2:
        return {}
    n = np.log([r["n_dofs"] for r in ok])
    out = {}
    names = set().union(*(r["phases"] for r in ok)) | {"total"}
    for name in sorted(names):
        t = [r["total_s"] if name == "total" else r["phases"].get(name, 0.0) for r in ok]
        if min(t) <= 0 or t[-1] < SMALL_S:
            continue
        y = np.log(t)
        b_all = np.polyfit(n, y, 1)[0]
        b_last = (y[-1] - y[-2]) / (n[-1] - n[-2])
        out[name] = {"b_all": round(float(b_all), 2), "b_last": round(float(b_last), 2),
                     "largest_s": round(t[-1], 3), "share": round(t[-1] / ok[-1]["total_s"], 3)}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config")
    ap.add_argument("--refine", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--discretisations", nargs="+", default=["mortar"])
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument("--args", default="", help="more `app run` arguments, one string")
    args = ap.parse_args()
    config = (ROOT / args.config).resolve()
    try:
        k = n_interfaces(config)
    except (OSError, tomllib.TOMLDecodeError) as exc:
        ap.error(f"config {args.config}: {exc}")
    for disc in args.discretisations:
        extra = [f"--set=interface.{i}.discretisation=\"{disc}\"" for i in range(k)]
        extra += [f"--set={s}" for s in args.sets] + args.args.split()
        rows = []
        for level in args.refine:
            row = {"config": args.config, "discretisation": disc, "refine": level,
                   "ranks": args.ranks} | run(config, [*extra, "--refine", str(level)],
                                              args.ranks)
            rows.append(row)
            print(json.dumps(row), flush=True)
        print(json.dumps({"config": args.config, "discretisation": disc, "ranks": args.ranks,
                          "fit": fits(rows)}), flush=True)


if __name__ == "__main__":
    main()
