"""Audit the interface law on a run's output folder, step by step.

    .venv/bin/python scripts/check_interface_law.py OUT [--tol 1e-7]

Reads OUT/summary.json and OUT/step_NNNN.h5 and prints one JSON line per step with the
figures of app/output/law_audit.py (state against forces and motion, debonding for good,
slip accumulation, dissipation), then a line with the largest of each; exit status 1 when
one is beyond --tol (a count beyond 0), else 0; 2 with a one-line error when OUT has
nothing to audit (no summary.json, a run without interfaces, or no completed step).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from app.output.law_audit import LAW_TOL, audit_step, failed  # noqa: E402

KEYS = ("p_force", "q_force", "a_force", "c_force", "mu", "state", "debonded_step",
        "slip_increment", "slip")


def read_steps(out: Path) -> tuple[list[dict], list[float], float, float]:
    """Per step the /contact arrays and the summary's dissipation; the run's force and
    displacement scales (largest pair force or strength, largest |u|)."""
    summary = json.loads((out / "summary.json").read_text())
    arrays, diss, fs, us = [], [], 0.0, 0.0
    for k, st in enumerate(summary["steps"], 1):
        with h5py.File(out / f"step_{k:04d}.h5") as f:
            arrays.append({n: f["contact"][n][()] for n in KEYS})
            us = max(us, float(np.abs(f["displacement"][()]).max(initial=0.0)))
        diss.append(float(st.get("dissipation", 0.0)))
        c = arrays[-1]
        fs = max(fs, *(float(np.abs(c[n]).max(initial=0.0))
                       for n in ("p_force", "q_force", "a_force", "c_force")))
    return arrays, diss, fs, us


def nothing_to_audit(out: Path) -> str:
    """Why OUT cannot be audited (no summary.json, no interface, no completed step), or ""."""
    path = out / "summary.json"
    if not path.is_file():
        return f"{path} not found: OUT must be the --out folder of a run"
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        return f"{path} is not readable JSON ({exc})"
    if not summary.get("steps"):
        return (f"{out} has no completed step (status '{summary.get('status')}'): "
                "nothing to audit")
    if not summary.get("contact_interfaces"):
        return f"{out} is a run without [[interface]]: there is no interface law to audit"
    return ""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--tol", type=float, default=LAW_TOL)
    args = ap.parse_args(argv)
    problem = nothing_to_audit(args.out)
    if problem:
        print(f"error: {problem}", file=sys.stderr)
        return 2
    arrays, diss, fs, us = read_steps(args.out)
    worst: dict = {}
    prev = None
    for k, (c, d) in enumerate(zip(arrays, diss, strict=True), 1):
        fig = audit_step(c, prev, d, fs, us)
        print(json.dumps({"step": k} | fig))
        worst = {n: max(worst.get(n, 0), v) for n, v in fig.items()}
        prev = c
    bad = failed(worst, args.tol)
    print(json.dumps({"worst": worst, "failed": bad}))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
