"""The floors of the L2 definitions over many levels, with no runs beyond level 0: the
exact field (Hertz p or Cattaneo-Mindlin q) sampled at a study's level-0 pairs bisected l
times (JSON lines; README "Why L2(q) ... have no steady order").

    .venv/bin/python scripts/floor_orders.py OUT/study_dir [--field q|p] [--levels 9]
        [--ref-levels 1] [--method 4SD] [--reference 4SD]

Bisecting the level-0 pairs reproduces the pairs of the split levels within 1e-4 of their
spacing in the contact window (levels 1-4 of cattaneo_halfspace). The exact field takes
a, p0 (and Q/(mu P)) from the finest run of the reference method. Per level: floor_cf (the
closed-form interpolated L2 over |x| <= 1.5 a) and floor_ref (the ref_* definition against
the pairs REF_LEVELS finer), and theta_a, theta_c: where x = +a and x = +c fall between
the pairs (app/studies/field_breakdown.edge_phase); a last line lists the floors' observed orders.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's app
from field_breakdown import fail, reference_run, runs_of  # noqa: E402  (scripts/field_breakdown.py)

from app.closed_form import INTERPOLATED_L2_RANGE  # noqa: E402
from app.output.read import last_step_file, read_pairs  # noqa: E402
from app.studies.field_breakdown import bisect_pairs, edge_phase, floor_sequence, orders  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("study", type=Path)
    ap.add_argument("--field", choices=("q", "p"), default="q")
    ap.add_argument("--levels", type=int, default=9)
    ap.add_argument("--ref-levels", type=int, default=1)
    ap.add_argument("--method", default="4SD")
    ap.add_argument("--reference", default="4SD")
    args = ap.parse_args()
    ref = reference_run(args)
    exact, a, x0, c = ref["exact"], ref["a"], ref["x0"], ref["c"]
    level0 = runs_of(args.study, args.method).get(0)
    if level0 is None:
        fail(f"{args.study} has no level-0 run of --method {args.method} (L0_{args.method})")
    x = read_pairs(last_step_file(level0), 0, ("x",))["x"] - x0
    rows = floor_sequence(x, lambda t: exact(t + x0), INTERPOLATED_L2_RANGE * a, args.levels,
                          args.ref_levels)
    for r in rows:
        xl = bisect_pairs(x, r["level"])
        r["theta_a"] = edge_phase(xl, a)
        if c is not None:
            r["theta_c"] = edge_phase(xl, c)
        print(json.dumps({"field": args.field, **{k: round(v, 6) if isinstance(v, float)
                                                   else v for k, v in r.items()}}))
    print(json.dumps({"orders": args.field, "ref_levels": args.ref_levels,
                      **{k: [round(o, 2) for o in orders([r[k] for r in rows])]
                         for k in ("floor_cf", "floor_ref")}}))


if __name__ == "__main__":
    main()
