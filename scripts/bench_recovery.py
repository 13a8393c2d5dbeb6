"""Benchmark: the force recovery with kept columns S^-1 G_c^T against a solve with S a step.

Runs a scene (default: the 100-step, 2000-pair configs/hard/cattaneo_many.toml) in turn with
the kept columns (app/condensation/contact_columns.py, "columns") and without them
("dense": every step's u_c = S^-1 G_c^T lambda is a solve with the dense Cholesky factor
of S, and C = G_c S^-1 G_c^T is formed by one expression: the code before), each in its
own process, and prints one JSON line per run: the
recovery phase, the total, the peak memory of the compliance and recovery phases (MB), and
the largest difference of the last step's displacement from the first "dense" run,
relative to its largest entry. A run that fails prints its row with `error` (the app's
`error:` line) and the script exits 1 (before, 0).

    .venv/bin/python scripts/bench_recovery.py [--config C] [--repeat 2] [--ranks 1]
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from app_runner import ENV, ROOT, app_command, failure_reason

RUN = """
import sys
if sys.argv[1] == "dense":  # the code before: a solve with S a step, C by one expression
    import app.condensation.compliance_product as cp
    import app.condensation.contact_columns as cc
    cc.ContactColumns.apply = lambda self, lam: None
    def plain(gc, solve, keep=None):
        c = gc @ solve(gc.T.toarray())
        return 0.5 * (c + c.T)
    cp.compliance_product = plain
from app.cli import main
sys.exit(main(sys.argv[2:]))
"""


def run(mode: str, config: str, ranks: int, out: Path) -> dict:
    """One run in its own process; its summary's figures."""
    cmd = app_command([mode, "run", config, "--out", str(out), "--quiet"], ranks, RUN)
    res = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True)
    if res.returncode != 0:
        return {"error": failure_reason(res.stderr)}
    s = json.loads((out / "summary.json").read_text())
    t, mem = s["timings"], s["peak_memory_mb"]
    return {"n_dofs": s["n_dofs"], "n_pairs": s["n_pairs"], "n_steps": s["n_steps"],
            "recovery_s": round(t["recovery"], 3), "total_s": round(t["total"], 3),
            "recovery_share": round(t["recovery"] / t["total"], 4),
            "compliance_mb": mem.get("compliance"), "recovery_mb": mem.get("recovery")}


def last_u(out: Path) -> np.ndarray:
    """The last step file's displacement."""
    import h5py

    last = sorted(out.glob("step_*.h5"))[-1]
    with h5py.File(last) as f:
        return f["displacement"][()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default="configs/hard/cattaneo_many.toml")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--ranks", type=int, default=1)
    args = ap.parse_args()
    ref, failed = None, 0
    for i in range(args.repeat):
        for mode in ("dense", "columns"):
            out = Path(tempfile.mkdtemp(prefix="bench_recovery_"))
            try:
                row = {"config": args.config, "mode": mode, "run": i + 1, "ranks": args.ranks}
                row |= run(mode, args.config, args.ranks, out)
                if "error" not in row:
                    u = last_u(out)
                    ref = u if ref is None else ref
                    row["u_diff_rel"] = float(np.abs(u - ref).max() / np.abs(ref).max())
            finally:
                shutil.rmtree(out, ignore_errors=True)
            failed += "error" in row
            print(json.dumps(row), flush=True)
    raise SystemExit(1 if failed else 0)


if __name__ == "__main__":
    main()
