"""Benchmark: CPU seconds of the polygon self-intersection test (`crossing_sides` in
app/scene/shapes/polygon_simple.py) on a round outline and on a star of thin spikes (long
sides overlapping along both axes, the sweep's worst case), at a few corner counts.

    PYTHONPATH=. .venv/bin/python scripts/bench_polygon_simple.py [--corners 2000 10000]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from app.scene.shapes.polygon_simple import crossing_sides


def outline(kind: str, n: int) -> np.ndarray:
    """A counter-clockwise outline of n corners: a circle, or a star of n / 2 spikes."""
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    r = np.ones(n) if kind == "round" else np.where(np.arange(n) % 2 == 0, 1.0, 0.01)
    return np.c_[r * np.cos(t), r * np.sin(t)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corners", type=int, nargs="+", default=[2000, 10000])
    args = ap.parse_args()
    for kind in ("round", "star"):
        for n in args.corners:
            p = outline(kind, n)
            t0 = time.process_time()
            found = crossing_sides(p)
            print(json.dumps({"outline": kind, "corners": n, "crossing": found,
                              "cpu_s": round(time.process_time() - t0, 3)}))


if __name__ == "__main__":
    main()
