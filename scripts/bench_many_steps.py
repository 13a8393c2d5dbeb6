"""Benchmark: many load steps with many pairs (configs/hard/cattaneo_many.toml: the
Cattaneo-Mindlin scene in 100 steps with about 2000 pairs).

Runs `python -m app run CONFIG` and prints one JSON line: pairs, LCP size, steps, the phase
times, the first step's seconds and Lemke pivots, and the seconds per step after the first
(mean, median, max; wall time of the step: LCP, displacement recovery and output), the
Cattaneo-Mindlin errors of the last step and the worst KKT violation and LCP residual.

    .venv/bin/python scripts/bench_many_steps.py [--config C] [--ranks N] [extra app args]
"""

from __future__ import annotations

import argparse
import json
import statistics

from app_runner import ROOT, run_app


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "hard" / "cattaneo_many.toml"))
    ap.add_argument("--ranks", type=int, default=1)
    args, extra = ap.parse_known_args()
    s = run_app(args.config, extra, args.ranks)
    if "error" in s:
        print(json.dumps({"config": args.config, **s}))
        raise SystemExit(1)
    steps = s["steps"]
    later = [st["step_seconds"] for st in steps[1:]]
    pivots = [st["lemke_pivots"] for st in steps]
    ref = s.get("reference", {}).get("cattaneo", {})
    print(json.dumps({
        "config": args.config, "ranks": args.ranks, "n_dofs": s["n_dofs"],
        "n_pairs": s["n_pairs"], "lcp_size": steps[0]["lcp_size"], "steps": len(steps),
        "lcp_size_solved_max": max(st.get("lcp_size_solved", st["lcp_size"]) for st in steps),
        "lcp_phase_share": round(s["timings"]["lcp"] / s["timings"]["total"], 4),
        "status": s["status"],
        "timings_s": {k: round(v, 3) for k, v in s["timings"].items()},
        "first_step_s": round(steps[0]["step_seconds"], 3),
        "first_step_pivots": pivots[0],
        "later_step_s_mean": round(statistics.fmean(later), 3) if later else None,
        "later_step_s_median": round(statistics.median(later), 3) if later else None,
        "later_step_s_max": round(max(later), 3) if later else None,
        "later_pivots_mean": round(statistics.fmean(pivots[1:]), 1) if later else None,
        "pairs_in_contact_last_step": s["n_pairs"] - steps[-1]["states"]["open"],
        "max_lcp_residual": max(st["lcp_residual"] for st in steps),
        "max_kkt_violation": max(max(st["kkt"].values()) for st in steps),
        "stick_half_width_rel_error": ref.get("stick_half_width_rel_error"),
        "traction_l2_rel_error": ref.get("traction_l2_rel_error"),
    }), flush=True)


if __name__ == "__main__":
    main()
