"""Benchmark: do the named phases add up to the run's total?

Runs every scene in configs/ and configs/hard/ (and the Hertz scene with CS-FEM-1SD,
whose floating cylinder's hourglass modes take an eigen-solve) with
`python -m app run` and prints one JSON line per scene: the total seconds, the sum of the
phases in `timings`, their ratio, the largest phase, and the process's wall seconds seen
from here with what of them is in no phase (`wall_minus_total_s`: mpiexec's start, and
the end after summary.json is written: the interpreter's teardown, PetscFinalize).
Scenes that stop with exit 2 on purpose (hourglass_1sd.toml) are reported from their
summary all the same.

    .venv/bin/python scripts/bench_phases.py [--skip cattaneo_many] [--ranks N]
        [--only multibody cattaneo] [--repeat 3]   (--repeat: the median of each figure)
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

from app_runner import ENV, ROOT, app_command, failure_reason


def run(config: Path, extra: list[str], ranks: int) -> dict:
    out = Path(tempfile.mkdtemp(prefix="bench_phases_"))
    try:
        cmd = app_command(["run", str(config), "--out", str(out), "--quiet", *extra], ranks)
        started = time.perf_counter()
        res = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True)
        wall = time.perf_counter() - started
        path = out / "summary.json"
        if not path.exists():
            return {"error": failure_reason(res.stderr)}
        s = json.loads(path.read_text())
    finally:
        shutil.rmtree(out, ignore_errors=True)
    t = s.get("timings", {})
    if "total" not in t:
        return {"status": s.get("status"), "error": s.get("error", "no total")}
    phases = {k: v for k, v in t.items() if k != "total"}
    top = max(phases, key=phases.get)
    return {"status": s["status"], "total_s": round(t["total"], 3),
            "phases_s": round(sum(phases.values()), 3),
            "phases_over_total": round(sum(phases.values()) / t["total"], 4),
            "largest_phase": top, "wall_s": round(wall, 3),
            "wall_minus_total_s": round(wall - t["total"], 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--skip", nargs="*", default=["cattaneo_many"])
    ap.add_argument("--ranks", type=int, default=1)
    ap.add_argument("--only", nargs="*", default=None, metavar="STEM",
                    help="only these scenes (config file names without .toml)")
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    scenes = [(p, []) for p in sorted((ROOT / "configs").glob("*.toml"))]
    scenes += [(p, []) for p in sorted((ROOT / "configs" / "hard").glob("*.toml"))]
    scenes.append((ROOT / "configs" / "hertz.toml", ["--sd", "1"]))
    for stem in args.only or []:  # (before: an unknown or skipped stem ran nothing, exit 0)
        if stem not in {p.stem for p, _ in scenes}:
            ap.error(f"--only {stem}: no configs/{stem}.toml or configs/hard/{stem}.toml")
        if stem in args.skip:
            ap.error(f"--only {stem}: also in --skip")
    for path, extra in scenes:
        if path.stem in args.skip or (args.only is not None and path.stem not in args.only):
            continue
        line = {"config": str(path.relative_to(ROOT)), "args": extra, "ranks": args.ranks}
        print(json.dumps(line | _median([run(path, extra, args.ranks)
                                         for _ in range(args.repeat)])), flush=True)


def _median(rows: list[dict]) -> dict:
    """The first row with every number replaced by its median over the rows (all of them
    when one has an error: the first error)."""
    if len(rows) == 1 or any("error" in r for r in rows):
        return next((r for r in rows if "error" in r), rows[0])
    return {k: round(statistics.median(r[k] for r in rows), 4)
            if isinstance(v, float) else v for k, v in rows[0].items()} | {
            "repeat": len(rows)}


if __name__ == "__main__":
    main()
