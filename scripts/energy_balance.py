"""Energy balance of a run loaded by prescribed displacements, step by step.

    .venv/bin/python scripts/energy_balance.py OUT

For each step k: the work the supports did on the bodies, by the trapezoid rule,
W_k = (R_k + R_{k-1}) / 2 . (u_k - u_{k-1}) per support component (R its reaction, the
summary's `reactions`; u = the prescribed value x the step's load factor), the change of
strain energy dU_k and the frictional dissipation D_k (the summary's `dissipation`).
Prints one JSON line per step with W, dU, D and the residual W - dU - D, then their
sums. Without debonding the residual is the step discretisation of the trapezoid rule
(0 for a linear elastic step, which the bond is until it breaks); a step that debonds
pairs releases the energy the bond held, which is no frictional work: its residual is
that energy, and must not be negative (no energy made).

Supports must prescribe constant numbers (not expressions of x, y: their work is not one
reaction times one displacement); loads (`[[load]]`) are refused, as their work needs the
displacement of the loaded curve (scripts/mindlin_cycle.py does that for its scene).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


def support_names(supports: list[dict]) -> list[str]:
    """The summary's names of the supports: support:<on>, #2 ... for repeats."""
    seen: dict[str, int] = {}
    out = []
    for s in supports:
        n = seen[s["on"]] = seen.get(s["on"], 0) + 1
        out.append(f"support:{s['on']}" + (f"#{n}" if n > 1 else ""))
    return out


def balance(summary: dict) -> list[dict]:
    """Per step: work of the supports, strain energy change, dissipation, residual."""
    cfg = summary["provenance"]["config_resolved"]
    if any(cfg.get("load", [])) or any(b.get("body_force") for b in cfg.get("body", [])):
        raise ValueError("the config has loads or body forces, whose work is not computed "
                         "here: give the output of a run driven by support displacements only")
    supports = cfg.get("support", [])
    names = support_names(supports)
    rows, prev = [], None
    for st in summary["steps"]:
        u = {}
        for s, name in zip(supports, names, strict=True):
            for comp, key in (("ux", "Fx"), ("uy", "Fy")):
                v = s.get(comp)
                if v is None:
                    continue
                if not isinstance(v, int | float):
                    raise ValueError(f"{name}: {comp} = {v!r} is not a number")
                u[(name, key)] = float(v) * float(st["load_factor"].get(name, 0.0))
        r = {k: float(st["reactions"][k[0]][k[1]]) for k in u}
        energy = float(st["strain_energy"])
        if prev is None:  # from the unloaded start
            work = sum(0.5 * r[k] * u[k] for k in u)
            d_u = energy
        else:
            work = sum(0.5 * (r[k] + prev[1][k]) * (u[k] - prev[0][k]) for k in u)
            d_u = energy - prev[2]
        diss = float(st.get("dissipation", 0.0))
        rows.append({"step": st["step"], "work": work, "strain_energy_change": d_u,
                     "dissipation": diss, "residual": work - d_u - diss,
                     "debonded_this_step": st.get("debonded_this_step", 0)})
        prev = (u, r, energy)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    args = ap.parse_args(argv)
    try:
        summary = json.loads((args.out / "summary.json").read_text())
        rows = balance(summary)
    except (OSError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyError as exc:  # a summary without provenance, steps or reactions
        print(f"error: {args.out / 'summary.json'} has no key {exc}: give the OUT of a "
              "completed run", file=sys.stderr)
        return 2
    for r in rows:
        print(json.dumps(r))
    tot = {k: float(np.sum([r[k] for r in rows])) for k in
           ("work", "strain_energy_change", "dissipation", "residual")}
    print(json.dumps({"total": tot}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
