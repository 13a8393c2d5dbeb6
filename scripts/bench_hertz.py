"""Benchmark: the Hertz scene at several mesh sizes; per phase seconds, LCP size and
pivots, and the errors against Hertz. One JSON line per run.

    .venv/bin/python scripts/bench_hertz.py --mesh-size 0.5 0.25 0.125 [--ranks 1]

--mesh-size H scales every element size of configs/hertz.toml by H / 0.5 (the contact
refinement is 0.01 at H = 0.5).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "hertz.toml"))
    ap.add_argument("--mesh-size", type=float, nargs="+", default=[0.5, 0.25, 0.125])
    ap.add_argument("--ranks", type=int, default=1)
    args, extra = ap.parse_known_args()
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    for h in args.mesh_size:
        out = Path(tempfile.mkdtemp(prefix="bench_hertz_"))
        cmd = [sys.executable, "-m", "app", "run", args.config, "--out", str(out),
               "--mesh-size", str(h), "--quiet", *extra]
        if args.ranks > 1:
            cmd = [shutil.which("mpiexec") or "mpiexec", "-n", str(args.ranks), *cmd]
        res = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
        if res.returncode != 0:
            print(json.dumps({"mesh_size": h, "error": res.stderr.strip()[-500:]}))
            continue
        s = json.loads((out / "summary.json").read_text())
        st = s["steps"][-1]
        hz = s["reference"]["hertz"]
        print(json.dumps({
            "mesh_size": h, "ranks": s["ranks"], "method": s["label"],
            "n_dofs": s["n_dofs"], "n_pairs": s["n_pairs"], "lcp_size": st["lcp_size"],
            "lemke_pivots": st["lemke_pivots"],
            "timings_s": {k: round(v, 4) for k, v in s["timings"].items()},
            "p_max_rel_error": round(hz["p_max_rel_error"], 5),
            "half_width_rel_error": round(hz["half_width_rel_error"], 5),
            "pressure_l2_rel_error": round(hz["pressure_l2_rel_error"], 5),
        }), flush=True)
        shutil.rmtree(out, ignore_errors=True)


if __name__ == "__main__":
    main()
