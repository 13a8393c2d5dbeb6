"""Benchmark: the Hertz scene at several mesh sizes; per phase seconds, LCP size and
pivots, and the errors against Hertz. One JSON line per run.

    .venv/bin/python scripts/bench_hertz.py --mesh-size 0.5 0.25 0.125 [--ranks 1]

--mesh-size H scales every element size of configs/hertz.toml by H / 0.5 (the contact
refinement is 0.01 at H = 0.5).

Options the script does not know go to the app (e.g. `-ksp_type cg`); a run that fails
prints its row with `error` (the app's `error:` line) and the script exits 1.
"""

from __future__ import annotations

import argparse
import json

from app_runner import ROOT, run_app


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "hertz.toml"))
    ap.add_argument("--mesh-size", type=float, nargs="+", default=[0.5, 0.25, 0.125])
    ap.add_argument("--ranks", type=int, default=1)
    args, extra = ap.parse_known_args()
    failed = 0
    for h in args.mesh_size:
        s = run_app(args.config, ["--mesh-size", str(h), *extra], args.ranks)
        if "error" in s:
            print(json.dumps({"mesh_size": h, **s}), flush=True)
            failed += 1
            continue
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
    raise SystemExit(1 if failed else 0)


if __name__ == "__main__":
    main()
