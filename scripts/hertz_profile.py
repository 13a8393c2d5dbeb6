"""Where the Hertz L2(p) error comes from: one JSON line per run output folder.

    .venv/bin/python scripts/hertz_profile.py OUT [OUT ...] [--reference REF_OUT]
    .venv/bin/python scripts/hertz_profile.py --floor-table

A folder that is not a completed Hertz run (no summary.json, no Hertz reference, no step)
stops with `error:` and exit 2, as does no OUT without --floor-table.

For each `run --out` folder of a Hertz scene (last step, first interface), in % (of the
Hertz figures, or of p0 for the wobble):
- l2_interp, floor: `reference.hertz` of its summary (p interpolated linearly between
  pairs over |x| <= 1.5 a; the floor is the same error of the exact pressure sampled at the
  pairs, what the definition cannot resolve at that pair spacing), l2 (tributary, |x| < a),
  p_max and half_width errors;
- best: the smallest l2_interp that any non-negative pair values reach at these pair
  positions (`app.studies.l2_breakdown.interpolated_l2_best`), a bound no method can beat;
- wobble_max, wobble_n: the largest second difference of (p - p_Hertz) / p0 over
  consecutive pairs with |x| < 0.8 a, and how many exceed 0.2% (of n_inner pairs);
- with --reference (a finer run of the same scene): disc_l2, the tributary L2 over
  |x| < 0.9 a of p against the reference's p interpolated at the pairs (discretisation
  error without the model error), and model_l2, the reference against Hertz there;
  ref_l2_interp, l2_interp against the reference instead of Hertz; ref_sampled and
  ref_best, what an answer equal to the reference (sampled at the pairs, or the pair
  values closest to it) reads as l2_interp against Hertz; and ref_peak, ref_half_width,
  the reference's Hertz-shaped fit (p0' / p0 - 1, a' / a - 1, over |x| < 0.97 a): the
  model error of the scene.
--floor-table: the floor of pairs spaced a/n (n = 10, 20, 40, 80), placed symmetrically,
  as a function of how far inside the edge the last pair sits (fraction s of the spacing).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from app.closed_form import hertz_pressure, interpolated_l2_rel_error  # noqa: E402
from app.output.read import last_step_file, read_pairs  # noqa: E402
from app.studies.l2_breakdown import (  # noqa: E402
    hertz_form_fit,
    interpolated_l2_best,
    tributary_l2,
)

WOBBLE = 0.002  # second difference of (p - p_H) / p0 counted as a jump


def load(out: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Pair x, p, tributary length (sorted by x) of the last step, and the summary."""
    c = read_pairs(last_step_file(Path(out)), 0, ("x", "p", "length"))
    s = json.loads((Path(out) / "summary.json").read_text())
    return c["x"], c["p"], c["length"], s


def profile(out: str, ref: str | None) -> dict:
    x, p, length, s = load(out)
    h = s["reference"]["hertz"]
    a, p0 = h["a_hertz"], h["p0_hertz"]
    e = (p - hertz_pressure(x, a, p0)) / p0
    d2 = np.abs(e[2:] - 2 * e[1:-1] + e[:-2])[np.abs(x[1:-1]) < 0.8 * a]
    row = {"out": out, "n_dofs": s["n_dofs"], "l2_interp": h["pressure_l2_interp_rel_error"],
           "floor": h["pressure_l2_interp_floor"],
           "best": interpolated_l2_best(x, lambda t: hertz_pressure(t, a, p0), 1.5 * a)[0],
           "l2": h["pressure_l2_rel_error"],
           "p_max": h["p_max_rel_error"], "half_width": h["half_width_rel_error"],
           "wobble_max": float(d2.max(initial=0.0)), "wobble_n": int((d2 > WOBBLE).sum()),
           "n_inner": int(d2.size)}
    if ref is not None:
        xr, pr, lr, _ = load(ref)
        zone = np.abs(x) < 0.9 * a
        row["disc_l2"] = tributary_l2(length, p, np.interp(x, xr, pr), zone)
        row["model_l2"] = tributary_l2(lr, pr, hertz_pressure(xr, a, p0), np.abs(xr) < 0.9 * a)
        row.update(reference_bounds(x, p, xr, pr, a, p0))
    return {k: round(100 * v, 3) if isinstance(v, float) else v for k, v in row.items()}


def reference_bounds(x: np.ndarray, p: np.ndarray, xr: np.ndarray, pr: np.ndarray,
                     a: float, p0: float) -> dict:
    """The run (pairs x, p) against the reference run (xr, pr: a finer run of the same
    scene, standing for its converged solution): ref_l2_interp, l2_interp with the
    reference in place of Hertz; and what an answer that reproduces the reference reads
    against Hertz at the pairs x: ref_sampled (the reference's p at the pairs) and
    ref_best (the non-negative pair values closest to the reference,
    `interpolated_l2_best`), both as l2_interp against Hertz; and ref_peak,
    ref_half_width: the reference's Hertz-shaped fit (`hertz_form_fit`)."""
    hertz = lambda t: hertz_pressure(t, a, p0)  # noqa: E731
    conv = lambda t: np.interp(t, xr, pr)  # noqa: E731
    closest = interpolated_l2_best(x, conv, 1.5 * a)[1]
    peak, half = hertz_form_fit(xr, pr, a, p0)
    return {"ref_l2_interp": interpolated_l2_rel_error(x, p, conv, 1.5 * a),
            "ref_sampled": interpolated_l2_rel_error(x, conv(x), hertz, 1.5 * a),
            "ref_best": interpolated_l2_rel_error(x, closest, hertz, 1.5 * a),
            "ref_peak": peak, "ref_half_width": half}


def floor_table() -> None:
    a = 1.0
    for n in (10, 20, 40, 80):
        h, row = a / n, {}
        for s in np.linspace(0.0, 0.95, 20):
            xr = a + (np.arange(-n + 1, 2 * n) - s) * h  # a pair at a - s h, then a + (1-s) h
            xr = xr[xr > 0]
            x = np.concatenate([-xr[::-1], xr])
            row[f"{s:.2f}"] = round(100 * interpolated_l2_rel_error(
                x, hertz_pressure(x, a, 1.0), lambda t: hertz_pressure(t, a, 1.0), 1.5 * a,
                n_samples=200001), 3)
        print(json.dumps({"spacing": f"a/{n}", "floor_by_s": row}), flush=True)


def unusable(out: Path) -> str | None:
    """Why OUT is not a completed step of a Hertz run (None if it is one)."""
    try:
        s = json.loads((out / "summary.json").read_text())
    except (OSError, ValueError) as exc:
        return f"not a run's --out folder ({exc})"
    if "hertz" not in (s.get("reference") or {}):
        return "its summary.json has no Hertz reference (a scene with [reference] type hertz)"
    if not s.get("steps"):
        return f"no completed step (status {s.get('status')!r})"
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("outs", nargs="*")
    ap.add_argument("--reference")
    ap.add_argument("--floor-table", action="store_true")
    args = ap.parse_args()
    if not args.outs and not args.floor_table:
        ap.error("give run output folders (OUT ...) or --floor-table")
    for out in [*args.outs, *([args.reference] if args.reference else [])]:
        problem = unusable(Path(out))
        if problem:
            ap.error(f"{out}: {problem}")
    if args.floor_table:
        floor_table()
    for out in args.outs:
        print(json.dumps(profile(out, args.reference)), flush=True)


if __name__ == "__main__":
    main()
