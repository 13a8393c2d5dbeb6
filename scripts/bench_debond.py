"""Benchmark: the LCP time of debonding rounds with and without the LCP matrix's cache.

Runs a scene (default multibody.toml, whose bonded interface debonds over up to 25
re-solves of one load step at --refine 2) with each contact discretisation, alternately
with `-contact_lcp_cache 0` (every solve reads M afresh and factorizes its warm-start
basis twice: the code before the cache) and with the cache, --repeat times, so that both
see the same machine load. Prints one JSON line per run and per discretisation the
medians: the `lcp` phase, the seconds of the step with the most LCP solves
(`lcp_seconds`), its `lcp_solves` and Lemke pivots, and how far the cache's answers are
from the others (the largest relative difference of the interfaces' forces, and whether
every step's states and debonded pairs are the same).

    .venv/bin/python scripts/bench_debond.py configs/multibody.toml --refine 2 \
        --discretisations node-to-segment mortar mortar-smooth --repeat 3
"""

from __future__ import annotations

import argparse
import json
import statistics

from app_runner import ROOT, run_app
from bench_scale import n_interfaces

VARIANTS = {"no cache": ["-contact_lcp_cache", "0"], "cache": []}


def figures(summary: dict) -> dict:
    """The run's lcp phase and total, and the step with the most LCP solves."""
    steps = summary.get("steps") or [{}]
    big = max(steps, key=lambda s: s.get("lcp_solves", 0))
    return {"lcp_s": summary["timings"].get("lcp", 0.0), "total_s": summary["timings"]["total"],
            "step": big.get("step"), "step_lcp_s": big.get("lcp_seconds", 0.0),
            "lcp_solves": big.get("lcp_solves", 0), "pivots": big.get("lemke_pivots", 0)}


def agreement(ref: dict, other: dict) -> dict:
    """How far other's answers are from ref's: the largest difference of an interface's
    normal or tangential force relative to the largest such force, and whether every
    step's states and debonded pairs per interface are equal."""
    diff, scale, same = 0.0, 0.0, True
    for sa, sb in zip(ref.get("steps", []), other.get("steps", []), strict=True):
        for name, ia in sa.get("interfaces", {}).items():
            ib = sb["interfaces"][name]
            for key in ("normal_force", "tangential_force"):
                diff = max(diff, abs(ia[key] - ib[key]))
                scale = max(scale, abs(ia[key]))
            same &= ia["states"] == ib["states"] and \
                ia["debonded_pairs"] == ib["debonded_pairs"]
    return {"force_rel_diff": diff / scale if scale else 0.0, "same_states": same}


def medians(rows: list[dict]) -> dict:
    """Medians of the timed figures over the runs of one variant."""
    return {k: round(statistics.median(r[k] for r in rows), 4)
            for k in ("lcp_s", "step_lcp_s", "total_s")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config", nargs="?", default="configs/multibody.toml")
    ap.add_argument("--refine", type=int, default=2)
    ap.add_argument("--discretisations", nargs="+", default=["node-to-segment", "mortar"])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    try:
        k = n_interfaces(ROOT / args.config)
    except (OSError, ValueError) as exc:  # (TOMLDecodeError is a ValueError)
        ap.error(f"config {args.config}: {exc}")
    for disc in args.discretisations:
        base = [f"--set=interface.{i}.discretisation=\"{disc}\"" for i in range(k)]
        base += ["--refine", str(args.refine)]
        rows: dict[str, list[dict]] = {v: [] for v in VARIANTS}
        summaries: dict[str, dict] = {}
        for rep in range(args.repeat):
            for variant, extra in VARIANTS.items():
                s = run_app(args.config, base + extra)
                if "error" in s:
                    raise SystemExit(f"error: {disc}, {variant}: {s['error']}")
                summaries[variant] = s
                rows[variant].append(figures(s))
                print(json.dumps({"discretisation": disc, "variant": variant, "run": rep + 1,
                                  **rows[variant][-1]}), flush=True)
        print(json.dumps({"discretisation": disc, "refine": args.refine,
                          "repeat": args.repeat, "step": rows["cache"][-1]["step"],
                          "lcp_solves": rows["cache"][-1]["lcp_solves"],
                          **{v: medians(r) for v, r in rows.items()},
                          **agreement(summaries["no cache"], summaries["cache"])}), flush=True)


if __name__ == "__main__":
    main()
