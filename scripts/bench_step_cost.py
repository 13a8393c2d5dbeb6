"""Benchmark: does the cost of a load step grow with the number of steps?

Runs `python -m app run configs/patch.toml --set analysis.steps=N --set load.0.ramp=[1,N]`
(the pressure ramps over the N steps, so every step solves a new LCP) and prints one JSON
line: the mean `step_seconds` of the first and the last 100 steps and their ratio, the
same for the wall time between the ends of consecutive steps (`elapsed_seconds`
differences: everything in the step loop, summary.json included), the ratio of the
medians (less sensitive to a busy machine), the sizes of
summary.json and the XDMF indexes at the end, and the phases' sum over the total.

    .venv/bin/python scripts/bench_step_cost.py [--steps 1000] [--config C] [--ranks N]
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from app_runner import ENV, ROOT, failure_reason


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "patch.toml"))
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--window", type=int, default=100)
    ap.add_argument("--ranks", type=int, default=1)
    args = ap.parse_args()
    n, w = args.steps, args.window
    out = Path(tempfile.mkdtemp(prefix="bench_steps_"))
    try:
        cmd = [sys.executable, "-m", "app", "run", args.config, "--out", str(out), "--quiet",
               "--set", f"analysis.steps={n}", "--set", f"load.0.ramp=[1,{n}]"]
        if args.ranks > 1:
            cmd = [shutil.which("mpiexec") or "mpiexec", "-n", str(args.ranks), *cmd]
        res = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True)
        if res.returncode != 0:
            print(json.dumps({"error": failure_reason(res.stderr)}))
            raise SystemExit(1)
        s = json.loads((out / "summary.json").read_text())
        sizes = {p.name: p.stat().st_size for p in out.glob("*") if p.suffix in (".json",
                                                                               ".xdmf")}
    finally:
        shutil.rmtree(out, ignore_errors=True)
    steps = s["steps"]
    step_s = [st["step_seconds"] for st in steps]
    ends = [st.get("elapsed_seconds", 0.0) for st in steps]  # absent before this script
    wall = [b - a for a, b in zip(ends[:-1], ends[1:], strict=True)] or [0.0]  # steps 2..n
    t = s["timings"]
    phases = sum(v for k, v in t.items() if k != "total")
    first, last = statistics.fmean(step_s[:w]), statistics.fmean(step_s[-w:])
    wfirst, wlast = statistics.fmean(wall[:w]), statistics.fmean(wall[-w:])
    print(json.dumps({
        "config": args.config, "steps": len(steps), "ranks": args.ranks, "status": s["status"],
        "step_seconds_first_mean": round(first, 5), "step_seconds_last_mean": round(last, 5),
        "step_seconds_last_over_first": round(last / first, 3),
        "step_seconds_median_last_over_first": round(
            statistics.median(step_s[-w:]) / statistics.median(step_s[:w]), 3),
        "wall_per_step_first_mean": round(wfirst, 5), "wall_per_step_last_mean": round(wlast, 5),
        "wall_per_step_last_over_first": round(wlast / wfirst, 3) if wfirst else None,
        "file_bytes": sizes, "total_s": round(t["total"], 2),
        "phases_over_total": round(phases / t["total"], 4),
    }), flush=True)


if __name__ == "__main__":
    main()
