"""Proportional (oblique) loading of the Cattaneo scene: Q = k P from zero, k < mu.

    .venv/bin/python scripts/oblique_path.py [--refine L] [--steps N] [--k 0.1] [--out DIR]

Mindlin and Deresiewicz: when the tangential force grows in proportion to the normal one
with k = dQ/dP < mu, nothing slips and q(x) = k p(x) (in 2D with equal materials the
tangential surface displacement of a shear traction s(x) is the normal one of a pressure
s(x), so k times each increment of the Hertz pressure moves the contact rigidly). On
configs/cattaneo_aligned.toml (level L) the approach is applied in N equal steps, first
alone (giving P_k), then again with Q_k = k P_k on the flat top; printed: L2 of
q - k p over the pairs (tributary weights) relative to that of k p, the same less the
q the approach alone locks in, and the slipping pairs of the last step. The incremental
law sticks a pair that closes during a step to where it was at the step's start, so the
figure falls with N as well as with L.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
APPROACH = "ramp = [1, 1]"
TANGENTIAL = "total_force = [1.104846, 0.0]\nramp = [2, 6]"


def run(cfg_text: str, out: Path, refine: int) -> dict:
    cfg = out.with_suffix(".toml")
    cfg.write_text(cfg_text)
    res = subprocess.run([sys.executable, "-m", "app", "run", str(cfg), "--refine",
                          str(refine), "--out", str(out)], cwd=ROOT, capture_output=True,
                         text=True, env=os.environ | {"OMPI_ALLOW_RUN_AS_ROOT": "1",
                                                      "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"})
    if res.returncode:
        raise SystemExit(f"error: {cfg}: {res.stderr.strip().splitlines()[-1]}")
    return json.loads((out / "summary.json").read_text())


def last_contact(out: Path, step: int) -> dict:
    with h5py.File(out / f"step_{step:04d}.h5") as f:
        return {n: f["contact"][n][()] for n in ("p", "q", "length", "state")}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--refine", type=int, default=0)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--k", type=float, default=0.1, help="Q / P (below mu = 0.2)")
    ap.add_argument("--out", type=Path, default=Path("/tmp/oblique_path"))
    args = ap.parse_args(argv)
    src = (ROOT / "configs" / "cattaneo_aligned.toml").read_text()
    if APPROACH not in src or TANGENTIAL not in src:
        raise SystemExit("error: configs/cattaneo_aligned.toml is not the expected scene")
    mu = float(tomllib.loads(src)["interface"][0]["mu"])
    if not 0.0 < args.k < mu:  # k >= mu: the tangential load exceeds friction, no equilibrium
        ap.error(f"--k {args.k}: Q / P must be above 0 and below mu = {mu:g}")
    if args.steps < 1 or args.refine < 0:
        ap.error("--steps must be at least 1 and --refine at least 0")
    n = args.steps
    src = src.replace("steps = 6", f"steps = {n}").replace(APPROACH, f"ramp = [1, {n}]")
    args.out.mkdir(parents=True, exist_ok=True)
    normal = run(src.replace(TANGENTIAL, "total_force = [0.0, 0.0]"), args.out / "normal",
                 args.refine)
    P = [s["interfaces"]["contact"]["normal_force"] for s in normal["steps"]]
    run(src.replace(TANGENTIAL, f"total_force = [1.0, 0.0]\nhistory = "
                    f"{[args.k * p for p in P]}"), args.out / "oblique", args.refine)
    c, c0 = last_contact(args.out / "oblique", n), last_contact(args.out / "normal", n)
    kp = args.k * c["p"]
    if np.abs(c["q"] + kp).max() < np.abs(c["q"] - kp).max():  # q along t, t along -x
        kp = -kp
    w = c["length"]
    norm = np.sqrt(np.sum(w * kp**2))
    l2 = np.sqrt(np.sum(w * (c["q"] - kp) ** 2)) / norm
    l2_less = np.sqrt(np.sum(w * (c["q"] - c0["q"] - kp) ** 2)) / norm
    print(json.dumps({"refine": args.refine, "steps": n, "k": args.k, "n_pairs": int(w.size),
                      "l2_q_minus_kp": float(l2), "l2_less_normal_locked_in": float(l2_less),
                      "slipping_pairs": int(np.sum((c["state"] == 2) | (c["state"] == 3)))}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
