"""Benchmark: Lemke pivots and seconds per load step with and without warm starts
(the previous step's complementary basis), for the Cattaneo and bonded scenes.

    .venv/bin/python scripts/bench_warm_start.py [--scenes cattaneo bonded] [--mesh-size H]

Prints one JSON line per scene and setting with the per-step pivots and seconds and their
totals.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import tomllib
from pathlib import Path

from app.config import parse_config
from app.run import RunOptions, run

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", nargs="+", default=["cattaneo", "bonded"])
    ap.add_argument("--mesh-size", type=float, default=None)
    args = ap.parse_args()
    missing = [sc for sc in args.scenes if not (ROOT / "configs" / f"{sc}.toml").is_file()]
    if missing:
        ap.error(f"--scenes {missing[0]}: no configs/{missing[0]}.toml (give the names of "
                 "configs/*.toml, e.g. cattaneo bonded)")
    if args.mesh_size is not None and not args.mesh_size > 0:
        ap.error(f"--mesh-size {args.mesh_size}: must be a number > 0")
    for scene in args.scenes:
        path = ROOT / "configs" / f"{scene}.toml"
        raw = tomllib.loads(path.read_text())
        for warm in (False, True):
            raw.setdefault("analysis", {})["warm_start"] = warm
            cfg = parse_config(raw, path)
            scale = args.mesh_size / cfg.mesh_size if args.mesh_size else 1.0
            with tempfile.TemporaryDirectory() as tmp:
                s = run(cfg, RunOptions(out=Path(tmp), quiet=True, mesh_scale=scale))
            steps = s["steps"]
            print(json.dumps({
                "scene": scene, "warm_start": warm, "n_pairs": s["n_pairs"],
                "lcp_size": steps[-1]["lcp_size"],
                "pivots_per_step": [st["lemke_pivots"] for st in steps],
                "seconds_per_step": [round(st["lcp_seconds"], 4) for st in steps],
                "lcp_solves_per_step": [st["lcp_solves"] for st in steps],
                "total_pivots": sum(st["lemke_pivots"] for st in steps),
                "total_lcp_seconds": round(sum(st["lcp_seconds"] for st in steps), 4),
            }), flush=True)


if __name__ == "__main__":
    main()
