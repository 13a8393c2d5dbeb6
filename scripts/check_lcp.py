"""Adversarial check of the LCP solvers; prints JSON lines.

    .venv/bin/python scripts/check_lcp.py                 # 20 rounds, seed 0
    .venv/bin/python scripts/check_lcp.py --rounds 3 --no-large --solver lemke

Each round draws the cases of `app.interface.audit_cases` (random P-matrices, symmetric positive
(semi)definite, non-symmetric PSD, degenerate integer data, rows and symmetric scalings by
1e-8..1e8, the project's modified Coulomb LCPs on spring lattices: supported, floating,
nearly singular and singular compliances, mu 0 / 0.3 / 1, infeasible ones, and larger
LCPs), adds warm-start variants (wrong, infeasible, degenerate bases, wrong sizes), and
solves each with every solver of `app.lcp.audit.solvers`. Every case that is not "ok" is
one line {"finding": ...}; then one line per (solver, class) with the counts of outcomes,
one per group of classes (all solvers), and a last line {"summary": ...} with the totals
per outcome. Exit status 1 when any outcome is a failure (wrong, missed, hang, exception).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter, defaultdict

import numpy as np

from app.interface import audit_cases as ac
from app.lcp.audit import FAILURES, Reference, classify, solvers


def cases(seed: int, large: bool) -> list[tuple[ac.Case, Reference]]:
    """The cases of one round (seeded) with their warm-start variants, each with its
    reference (shared by a case's variants)."""
    rng = np.random.default_rng(seed)
    base = (ac.small_cases(rng) + ac.degenerate_cases(rng) + ac.scaled_cases(rng)
            + ac.infeasible_cases(rng) + ac.contact_cases(rng) + ac.structured_cases(rng))
    if large:
        base += ac.large_cases(rng) + ac.large_twin_cases(rng)
    out = []
    for c in base:
        ref = Reference(c)
        out.append((c, ref))
        sol = ref.sols[0] if ref.sols else None
        out += [(w, ref) for w in ac.warm_variants(c, rng, sol)]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=20, help="rounds of cases (default 20)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the first round")
    ap.add_argument("--no-large", action="store_true", help="skip the n = 30-420 cases")
    names = sorted(solvers())  # metavar: argparse's usage line drops the parentheses of
    ap.add_argument("--solver", action="append", choices=names, metavar="SOLVER",  # a name
                    help="only this solver (repeatable; default: all): "
                         + ", ".join(f"'{n}'" for n in names))
    args = ap.parse_args(argv)
    if args.rounds < 1:
        ap.error("--rounds must be at least 1")
    counts: dict[tuple[str, str], Counter] = defaultdict(Counter)
    for r in range(args.rounds):
        for case, ref in cases(args.seed + r, not args.no_large):
            for name, solve in solvers().items():
                if args.solver and name not in args.solver:
                    continue
                row = classify(case, solve, ref)
                counts[(name, case.cls)][row["outcome"]] += 1
                if row["outcome"] != "ok":
                    print(json.dumps({"finding": row, "solver": name, "class": case.cls,
                                      "n": int(case.q.size), "round": args.seed + r,
                                      "kw": _kw(case.kw)}), flush=True)
    total, groups = Counter(), defaultdict(Counter)
    for (name, cls), c in sorted(counts.items()):
        total.update(c)
        groups[ac.group(cls)].update(c)
        print(json.dumps({"solver": name, "class": cls, "cases": sum(c.values()), **c}))
    for g, c in groups.items():
        print(json.dumps({"group": g, "cases": sum(c.values()), **c}))
    print(json.dumps({"summary": {"cases": sum(total.values()), **total},
                      "rounds": args.rounds, "seed": args.seed}))
    return 1 if any(total[f] for f in FAILURES) else 0


def _kw(kw: dict) -> dict:
    """The solver's keyword arguments as JSON (a basis as its indices)."""
    return {k: (np.flatnonzero(v).tolist() if isinstance(v, np.ndarray) else v)
            for k, v in kw.items()}


if __name__ == "__main__":
    sys.exit(main())
