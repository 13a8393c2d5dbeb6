"""Mesh random rectangles with a named point near a side (app/mesh/near_points.py).

    .venv/bin/python scripts/check_near_points.py [--n 60] [--lo 1e-5] [--hi 0.5] [--seed 0]

Each case: a rectangle (width 1-3, height 0.5-2), an element size h (0.05-0.3) and a
named point at a distance d from a random side, d / h log-uniform in [lo, hi], inside
the body. A case passes when the mesh builds, passes the mesh checks (app/mesh/checks.py,
the fold check included), covers the rectangle's area to 1e-9 and has a node at the
named point. Prints one JSON line:
the cases, how many passed, and the first failures with their message.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from app.errors import InputError  # noqa: E402
from app.mesh.build import build_mesh  # noqa: E402
from app.mesh.checks import check_scene  # noqa: E402
from app.scene import parse_scene  # noqa: E402
from app.scene.geometry import polygon_areas  # noqa: E402


def case(rng: np.random.Generator, lo: float, hi: float) -> dict:
    """One random rectangle, size and near-side point (config dict and its figures)."""
    w, t, h = rng.uniform(1.0, 3.0), rng.uniform(0.5, 2.0), rng.uniform(0.05, 0.3)
    d = h * float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
    s, along = int(rng.integers(4)), rng.uniform(0.2, 0.8)
    xy = [[along * w, d], [w - d, along * t], [along * w, t - d], [d, along * t]][s]
    cfg = {"mesh": {"size": h}, "points": {"m": xy}, "body": [{"name": "r", "shape": {
        "type": "polygon", "points": [[0, 0], [w, 0], [w, t], [0, t]]}}]}
    return {"cfg": cfg, "area": w * t, "d_over_h": d / h}


def meshes(c: dict) -> str | None:
    """None when the case meshes cleanly, else why not (one line)."""
    try:
        m = build_mesh(parse_scene(c["cfg"]))
        check_scene(m, [])
    except (InputError, ValueError) as exc:
        return str(exc).splitlines()[0]
    area = float(polygon_areas(m.points[m.quads]).sum())
    if abs(area - c["area"]) > 1e-9 * c["area"]:
        return f"area {area:.6g}"
    node = m.points[m.point_groups["m"]].reshape(-1, 2)[0]
    gap = float(np.hypot(*(node - np.asarray(c["cfg"]["points"]["m"]))))
    return None if gap <= 1e-9 else f"the named point's node is {gap:.3g} away"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=60)
    ap.add_argument("--lo", type=float, default=1e-5)
    ap.add_argument("--hi", type=float, default=0.5)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    failures = []
    for _ in range(args.n):  # a few dozen gmsh runs: not a hot path
        c = case(rng, args.lo, args.hi)
        why = meshes(c)
        if why is not None:
            failures.append({"d_over_h": round(c["d_over_h"], 8), "why": why})
    print(json.dumps({"cases": args.n, "passed": args.n - len(failures), "lo": args.lo,
                      "hi": args.hi, "seed": args.seed, "failures": failures[:5]}))


if __name__ == "__main__":
    main()
