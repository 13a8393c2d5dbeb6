"""Where the Hertz L2(p) error of a study sits, per level of one method (JSON lines):
tributary L2 and its core / edge parts, the worst pair, the floor of the tributary
definition for tributary averages, and the interpolated L2 with its floor.

    .venv/bin/python scripts/l2_breakdown.py OUT/study_dir [--method 4SD] [--core 0.95]

Reads OUT/L<level>_<method>/summary.json (the Hertz a, p0 and centre) and the last
step's contact data; see app/studies/l2_breakdown.py for the definitions. A folder that is
not a study, or a method it did not run, stops with `error:` and exit 2 (before: no line,
exit 0). Runs without their row in study.csv (interrupted or failed) are left out (before,
a KeyError traceback on an interrupted study).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # this checkout's app
from app.output.read import read_pairs  # noqa: E402
from app.studies.l2_breakdown import pressure_breakdown  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from field_breakdown import runs_of  # noqa: E402  (scripts/field_breakdown.py)


def level_row(run: Path, core: float) -> dict:
    s = json.loads((run / "summary.json").read_text())
    ref = s["reference"]
    hz, x0 = ref["hertz"], ref.get("center_x", 0.0)
    c = read_pairs(run / f"step_{len(s['steps']):04d}.h5", 0, ("x", "p", "length"))
    x, p, length = c["x"], c["p"], c["length"]
    b = pressure_breakdown(x - x0, p, length, hz["a_hertz"], hz["p0_hertz"], core)
    return {"n_dofs": s["n_dofs"], "n_pairs": s["n_pairs"],
            **{k: round(v, 7) for k, v in b.items()},
            "l2_summary": round(hz["pressure_l2_rel_error"], 7),
            "l2_interp": round(hz["pressure_l2_interp_rel_error"], 7),
            "l2_interp_floor": round(hz["pressure_l2_interp_floor"], 7)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("study", type=Path)
    ap.add_argument("--method", default="4SD")
    ap.add_argument("--core", type=float, default=0.95, help="core |x| < CORE a")
    args = ap.parse_args()
    if not (args.study / "study.csv").is_file():
        ap.error(f"{args.study} is not a study's folder (no study.csv): give the --out "
                 "folder of `python -m app study`")
    runs = sorted(runs_of(args.study, args.method).values(),  # completed runs only
                  key=lambda d: int(re.match(r"L(\d+)_", d.name).group(1)))
    if not runs:
        ap.error(f"{args.study} has no runs of --method {args.method} (L<level>_"
                 f"{args.method})")
    for run in runs:
        print(json.dumps({"level": int(run.name[1:].split("_")[0]), "method": args.method,
                          **level_row(run, args.core)}), flush=True)


if __name__ == "__main__":
    main()
