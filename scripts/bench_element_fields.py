"""Benchmark: the per-step element fields (stress, von Mises, energy) of a run's output,
with the strain matrices formed every step (as before) and formed once per run
(`app.discretisation.bulk.element_operators`, what a run of several steps does now).

    .venv/bin/python scripts/bench_element_fields.py [--config C] [--refine N] [--repeat K]

Prints one JSON line: elements, seconds per step each way (median of K), their ratio,
the one-off cost of the operators, their memory and the largest difference of the fields.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
import tomllib
from pathlib import Path

import numpy as np

from app.config import parse_config
from app.discretisation.bulk import element_fields, element_operators
from app.errors import InputError
from app.run import RunOptions, build_scene_mesh, make_discretisation

ROOT = Path(__file__).resolve().parents[1]


def _median_seconds(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=str(ROOT / "configs" / "hard" / "cattaneo_many.toml"))
    ap.add_argument("--refine", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    if args.repeat < 1 or args.refine < 0:
        ap.error("--repeat must be at least 1 and --refine at least 0")
    path = Path(args.config)
    try:
        cfg = parse_config(tomllib.loads(path.read_text()), path)
    except (OSError, ValueError, InputError) as exc:  # (TOMLDecodeError is a ValueError)
        ap.error(f"config {args.config}: {exc}")
    opts = RunOptions(out=Path("/dev/null"), quiet=True, refine=args.refine)
    mesh = build_scene_mesh(cfg, opts)
    disc = make_discretisation(cfg, opts)
    elements = np.arange(mesh.n_elements)
    u = np.random.default_rng(0).standard_normal(2 * mesh.n_nodes) * 1e-3
    t0 = time.perf_counter()
    ops = element_operators(mesh, disc, elements)
    setup = time.perf_counter() - t0
    before = _median_seconds(lambda: element_fields(mesh, disc, u, elements), args.repeat)
    after = _median_seconds(lambda: element_fields(mesh, disc, u, elements, operators=ops),
                            args.repeat)
    a = element_fields(mesh, disc, u, elements)
    b = element_fields(mesh, disc, u, elements, operators=ops)
    diff = max(float(np.abs(a[k] - b[k]).max()) for k in a)
    print(json.dumps({"config": str(path), "refine": args.refine, "method": disc.label,
                      "elements": int(mesh.n_elements), "repeat": args.repeat,
                      "per_step_s_formed_each_step": round(before, 5),
                      "per_step_s_formed_once": round(after, 5),
                      "ratio": round(after / before, 3), "operators_once_s": round(setup, 5),
                      "operators_mb": round(sum(b_.nbytes + w.nbytes for b_, w in ops) / 2**20,
                                            1),
                      "max_abs_field_difference": diff}))


if __name__ == "__main__":
    main()
