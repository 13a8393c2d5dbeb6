"""Where a study's ref_traction_l2 (or ref_pressure_l2) sits, per level of one method, and
the floor of that definition (JSON lines; README "Why L2(q) ... have no steady order").

    .venv/bin/python scripts/field_breakdown.py OUT/study_dir [--method 4SD] [--field q|p]
        [--reference 4SD] [--band 1.0]

Per level: the error against the finest level of the reference method, recomputed as in
app/studies/reference_errors.py and split (app/studies/field_breakdown.py) into bands of
+-BAND x the level's pair spacing around the contact edges +-a (`edge`), the stick/slip
boundaries +-c (`stick`, q only) and the contact edges of the normal steps before the last one
(`lockin`: the level's own and the reference's), and the rest (`core`); `nodal`, the
error at the level's own pairs only (app/studies/field_breakdown.nodal_l2: no interpolation
between pairs, floor 0); `floor_ref`, the
same error of the exact field (Hertz p or Cattaneo-Mindlin q, with a, p0, Q/(mu P) of the
reference run) sampled at the level's pairs, and its parts `floor_<band>`; `floor_cf`, the
closed-form interpolated L2 of the exact field sampled at the pairs (the floor of
err_*_l2_interp); and `lockin_rms`, `lockin_max`: q over mu p0 at the end of the normal
steps (rms over |x| < a, max |q|), which theory says is 0. A last line lists the observed
orders of every column. A folder that is not a study, a missing method, `--field q` on a
study without Cattaneo's reference (Hertz: `--field p`), or fewer than 2 levels stop with
`error:` and exit 2.
"""

from __future__ import annotations

import argparse
import csv
import json
import re
import sys
from pathlib import Path
from typing import NoReturn

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's app
from app.closed_form import (  # noqa: E402
    INTERPOLATED_L2_RANGE,
    cattaneo_traction,
    hertz_pressure,
    interpolated_l2_rel_error,
)
from app.output.read import last_step_file, read_pairs  # noqa: E402
from app.studies.field_breakdown import field_breakdown, nodal_l2, orders  # noqa: E402
from app.studies.reference_errors import contact_window  # noqa: E402


def fail(msg: str) -> NoReturn:
    """Stop with one `error:` line and exit 2 (bad input, not a crash)."""
    print(f"error: {msg}", file=sys.stderr)
    raise SystemExit(2)


def runs_of(study: Path, method: str) -> dict[int, Path]:
    """level -> run folder of the method's runs that have their row in study.csv: a run
    the study did not complete (interrupted, failed: listed in study_tables.md) has no
    results to break down (before, a KeyError traceback, or, as the reference, a run
    without results)."""
    done = completed_levels(study, method)
    return {int(m.group(1)): d for d in study.glob(f"L*_{method}")
            if (m := re.match(r"L(\d+)_", d.name)) and int(m.group(1)) in done}


def completed_levels(study: Path, method: str) -> set[int]:
    """The levels of the method's rows in OUT/study.csv (none without the file)."""
    path = study / "study.csv"
    if not path.is_file():
        return set()
    with open(path, newline="") as fh:
        return {int(r["level"]) for r in csv.DictReader(fh) if r["method"] == method}


def normal_steps(run: Path) -> list[int]:
    """Steps at which every prescribed load's factor is 0 (only supports move)."""
    s = json.loads((run / "summary.json").read_text())
    return [st["step"] for st in s["steps"]
            if all(v == 0 for k, v in st["load_factor"].items() if k.startswith("load:"))]


def earlier_edges(run: Path) -> np.ndarray:
    """Outermost loaded pair positions at the normal steps whose contact is narrower than
    at the last normal step (the edges that the later steps lock in)."""
    steps = normal_steps(run)
    ext = []
    for k in steps:
        c = read_pairs(run / f"step_{k:04d}.h5", 0, ("x", "p"))
        inside = c["x"][c["p"] > 0]
        ext.append((inside.min(), inside.max()) if inside.size else (np.nan, np.nan))
    if not ext:
        return np.empty(0)
    last = ext[-1][1] - ext[-1][0]
    return np.array([e for lo, hi in ext if hi - lo < 0.99 * last for e in (lo, hi)])


def lockin(run: Path, a: float, p0: float, mu: float, x0: float) -> tuple[float, float]:
    steps = normal_steps(run)
    if not steps or mu <= 0:
        return np.nan, np.nan
    c = read_pairs(run / f"step_{steps[-1]:04d}.h5", 0, ("x", "q"))
    q = c["q"][np.abs(c["x"] - x0) < a] / (mu * p0)
    return float(np.sqrt(np.mean(q**2))), float(np.abs(q).max(initial=0.0))


def exact_field(ref_summary: dict, field: str, mu: float):
    r = ref_summary["reference"]
    hz, x0 = r["hertz"], r.get("center_x", 0.0)
    a, p0 = hz["a_hertz"], hz["p0_hertz"]
    if field == "p":
        return (lambda s: hertz_pressure(s - x0, a, p0)), a, p0, x0, None
    ca = r["cattaneo"]
    sign = float(np.sign(ca["Q"])) or 1.0
    return ((lambda s: sign * cattaneo_traction(s - x0, a, p0, mu, ca["Q_over_muP"])),
            a, p0, x0, ca["stick_half_width_exact"])


def _arguments() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("study", type=Path)
    ap.add_argument("--method", default="4SD")
    ap.add_argument("--reference", default="4SD")
    ap.add_argument("--field", choices=("q", "p"), default="q")
    ap.add_argument("--band", type=float, default=1.0, help="band half-width, pair spacings")
    return ap.parse_args()


def reference_run(args: argparse.Namespace) -> dict:
    """The reference run (the reference method's finest level): its folder, pairs, the
    exact field and its a, p0, x0, c, the contact window and its earlier contact edges."""
    if not (args.study / "study.csv").is_file():
        fail(f"{args.study} is not a study's folder (no study.csv): give the --out folder "
             "of `python -m app study`")
    refs = runs_of(args.study, args.reference)
    if not refs:
        fail(f"{args.study} has no runs of --reference {args.reference} (L<level>_"
             f"{args.reference}): give a method of the study")
    run = refs[max(refs)]
    s = json.loads((run / "summary.json").read_text())
    ref = s.get("reference", {})
    if "hertz" not in ref:
        fail(f"{run} has no Hertz reference: a study of a contact scene with a "
             "[reference] table of type hertz or cattaneo is needed")
    if args.field == "q" and "cattaneo" not in ref:
        fail(f"--field q needs a Cattaneo study ({run} has no cattaneo reference): use "
             "--field p")
    pairs = read_pairs(last_step_file(run), 0, ("x", "p", "q", "mu"))
    mu = float(pairs["mu"].max())
    exact, a, p0, x0, c = exact_field(s, args.field, mu)
    return {"run": run, "pairs": pairs, "mu": mu, "exact": exact, "a": a, "p0": p0, "x0": x0,
            "c": c, "window": contact_window(pairs["x"], pairs["p"]),
            "edges": earlier_edges(run)}


def _level_row(args: argparse.Namespace, ref: dict, level: int, run: Path,
               study_value: float) -> dict:
    """One level's breakdown of the method's error and of the floor (see the docstring)."""
    exact, a, x0, c, win = ref["exact"], ref["a"], ref["x0"], ref["c"], ref["window"]
    xr, fr = ref["pairs"]["x"], ref["pairs"][args.field]
    d = read_pairs(last_step_file(run), 0, ("x", "p", "q"))
    x = d["x"]
    h = float(np.median(np.diff(x[np.abs(x - x0) < a])))
    bands = {"edge": x0 + np.array([-a, a])}
    if c is not None:
        bands["stick"] = x0 + np.array([-c, c])
        bands["lockin"] = np.r_[earlier_edges(run), ref["edges"]]
    b = field_breakdown(x, d[args.field], xr, fr, win, bands, args.band * h)
    fb = field_breakdown(x, exact(x), xr, exact(xr), win, bands, args.band * h)
    lr, lm = lockin(run, a, ref["p0"], ref["mu"], x0) if c is not None else (np.nan, np.nan)
    return {"level": level, "method": args.method, "pairs": int(x.size),
            "h_over_a": round(h / a, 5), "study_csv": study_value, **b,
            "nodal": nodal_l2(x, d[args.field], xr, fr, win),
            "floor_ref": fb["total"],  # = sampled_floor(x, xr, exact, win)
            **{f"floor_{k}": v for k, v in fb.items() if k != "total"},
            "floor_cf": interpolated_l2_rel_error(x - x0, exact(x), lambda t: exact(t + x0),
                                                  INTERPOLATED_L2_RANGE * a),
            "lockin_rms": lr, "lockin_max": lm}


def main() -> None:
    args = _arguments()
    ref = reference_run(args)
    study = {(r["level"], r["method"]): r for r in csv.DictReader(open(args.study / "study.csv"))}
    if len([r for r in runs_of(args.study, args.method).values() if r != ref["run"]]) < 2:
        fail(f"{args.study} has fewer than 2 levels of --method {args.method} besides the "
             "reference run: the orders need 2 or more")
    col = "ref_traction_l2" if args.field == "q" else "ref_pressure_l2"
    rows = []
    for level, run in sorted(runs_of(args.study, args.method).items()):
        if run == ref["run"]:
            continue
        value = float(study[(str(level), run.name.split("_", 1)[1])].get(col) or "nan")
        row = _level_row(args, ref, level, run, value)
        rows.append(row)
        print(json.dumps({k: round(v, 6) if isinstance(v, float) else v
                          for k, v in row.items()}), flush=True)
    keys = [k for k, v in rows[0].items() if isinstance(v, float) and k != "h_over_a"]
    print(json.dumps({"orders": args.method, **{k: [round(o, 2) for o in orders(
        [r[k] for r in rows])] for k in keys}}))


if __name__ == "__main__":
    main()
