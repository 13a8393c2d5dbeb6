"""Benchmark: assembly rate and MUMPS factorization time of the cantilever on 1 and 2 ranks.

Runs `python -m app run configs/cantilever.toml --mesh-size H` (under mpiexec for 2 ranks)
and prints one JSON line per run with elements, DOFs, assembly seconds, elements per second,
factorization seconds and the ratio assembly / factorization.

    .venv/bin/python scripts/bench_bulk.py --mesh-size 0.003162 --ranks 1 2

Options the script does not know go to the app (e.g. `-ksp_type cg`); a run that fails
prints its row with `error` (the app's `error:` line) and the script exits 1.
"""

from __future__ import annotations

import argparse
import json

from app_runner import ROOT, run_app


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "cantilever.toml"))
    ap.add_argument("--mesh-size", type=float, default=0.003162,
                    help="element size; 0.003162 gives about 10^6 elements (3162 x 316)")
    ap.add_argument("--ranks", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--sd", type=int, default=4)
    args, extra = ap.parse_known_args()
    failed = 0
    for ranks in args.ranks:
        s = run_app(args.config, ["--mesh-size", str(args.mesh_size), "--sd", str(args.sd),
                                  *extra], ranks)
        if "error" in s:
            print(json.dumps({"ranks": ranks, **s}), flush=True)
            failed += 1
            continue
        t = s["timings"]
        print(json.dumps({
            "ranks": ranks, "method": s["label"], "n_elements": s["n_elements"],
            "n_dofs": s["n_dofs"], "assembly_s": round(t["assembly"], 3),
            "assembly_elements_per_s": round(s["n_elements"] / t["assembly"]),
            "assembly_elements_per_s_per_rank": round(s["n_elements"] / t["assembly"] / ranks),
            "factorization_s": round(t["factorization"], 3),
            "assembly_over_factorization": round(t["assembly"] / t["factorization"], 3),
            "mesh_s": round(t["mesh"], 3), "solve_s": round(t["solve"], 3),
            "output_s": round(t["output"], 3), "total_s": round(t["total"], 3),
            "tip_deflection_rel_error": s.get("reference", {}).get("tip_deflection_rel_error"),
        }), flush=True)
    raise SystemExit(1 if failed else 0)


if __name__ == "__main__":
    main()
