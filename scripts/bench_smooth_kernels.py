"""Candidate masters of `mortar-smooth` against the shipped one (README "Smoothed master").

Each candidate replaces `app.contact.mortar_smooth.smooth_kernel` (or, for the quadratic
B-spline, `smooth_weights`) in the app process; one JSON line per candidate:

- `end_share`: an end node's share of a uniform traction on a uniform master (a segment's
  length: 0.5 is exact, the patch test at the master's ends), `node_value`: the master
  curve's value at an interior node for a field u_k = k^2 (0 interpolates the nodes);
- `multibody_<S>`: multibody `indent` with block2 at S, last step, largest |p - local
  quadratic fit| / max p over the closed pairs (%), and max p (0.08 is the default mesh);
- `indent`: configs/indent.toml as shipped (mu = 0.2), the same deviation (%);
- `indent_mu0`: the same scene frictionless.

    PYTHONPATH=. .venv/bin/python scripts/bench_smooth_kernels.py [--kernels cubic ...]
        [--block2-sizes 0.08 0.12 0.1 0.09 0.07 0.06 0.05]

Candidates (c(t) on |t| <= 1, times the node's divided second difference, as shipped):
`cubic` (shipped), `quintic-c2` (the C2 one: c'' = 0 at |t| = 1), `blend-0.4` (cubic +
0.4 (quintic - cubic)), `smoothstep` ((1/2 - t)_+^2 - (1 - 3t^2 + 2t^3) / 12: the
B-spline's kernel made zero-mean), `quartic` (C2, no quadratic reproduction) and
`bspline` (the first master, the quadratic B-spline: not exact at the ends).
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
from app_runner import ENV, ROOT
from bench_indent_ratio import quadratic_bspline_weights

sys.path.insert(0, str(ROOT))
from app.contact import mortar_smooth  # noqa: E402
from app.contact.smoothness import local_fit_deviation  # noqa: E402
from app.output.read import last_step_file, read_pairs  # noqa: E402

SHIPPED = mortar_smooth.smooth_kernel


def _quintic(t: np.ndarray) -> np.ndarray:
    """The cubic plus s (1/4 - s^2)^2, s = |t| - 1/2: C2, same shares and quadratic
    reproduction (the odd part about s = 0 changes only)."""
    s = np.abs(t) - 0.5
    return SHIPPED(t) + s * (0.25 - s * s) ** 2


def _blend(t: np.ndarray) -> np.ndarray:
    return 0.6 * SHIPPED(t) + 0.4 * _quintic(t)


def _smoothstep(t: np.ndarray) -> np.ndarray:
    r = np.abs(t)
    return np.clip(0.5 - r, 0.0, None) ** 2 - (1 - 3 * r * r + 2 * r ** 3) / 12


def _quartic(t: np.ndarray) -> np.ndarray:
    r = np.abs(t)
    return (1 - r) ** 3 * (1 - 5 * r) / 8


KERNELS: dict[str, Callable[[np.ndarray], np.ndarray] | None] = {
    "cubic": SHIPPED, "quintic-c2": _quintic, "blend-0.4": _blend,
    "smoothstep": _smoothstep, "quartic": _quartic, "bspline": None}


def bspline_weights(eta: np.ndarray, has_prev: np.ndarray, has_next: np.ndarray,
                    lengths: np.ndarray | None = None) -> np.ndarray:
    """The first master: the uniform quadratic B-spline, knots at the segments' midpoints,
    a missing neighbour reflected (2 x_a - x_b) and folded into a and b (the weights of
    `bench_indent_ratio.quadratic_bspline_weights`; lengths unused)."""
    return quadratic_bspline_weights(eta, has_prev, has_next)


def install(name: str) -> None:
    """Replace the shipped kernel (or weights) by candidate `name` in this process."""
    if KERNELS[name] is None:
        mortar_smooth.smooth_weights = bspline_weights
    else:
        mortar_smooth.smooth_kernel = KERNELS[name]


def curve_checks() -> dict:
    """End node's share (uniform master of 6 segments, the end has no kernel) and the
    curve's value at an interior node for u_k = k^2, from the installed weights."""
    eta = np.tile((np.arange(20000)[None, :] + 0.5) / 20000, (6, 1))  # midpoint rule
    has_prev, has_next = np.arange(6) > 0, np.arange(6) < 5
    w = mortar_smooth.smooth_weights(eta, has_prev, has_next, np.ones((6, 3)))
    share_end = w[1, 0].mean() + w[0, 1].mean()  # node 0: `a` of segment 0, `prev` of 1
    u = np.array([(k - 1.0) ** 2 for k in range(4)])  # prev, a, b, next of segment 2
    at_node = mortar_smooth.smooth_weights(np.zeros((1, 1)), has_prev[2:3], has_next[2:3],
                                           np.ones((1, 3)))
    value = float(at_node[:, 0, 0] @ u)  # at node a (u = 0 there)
    return {"end_share": round(float(share_end), 5), "node_value": round(value, 5)}


def run(name: str, config: str, sets: list[str], index: int) -> tuple[float, float]:
    """(largest deviation from the local fit (%), max p) of the last step's closed pairs of
    interface `index`, the app run with candidate `name` installed."""
    out = Path(tempfile.mkdtemp(prefix="smooth_kernels_"))
    hook = ("import sys; sys.path.insert(0, 'scripts'); import bench_smooth_kernels as b; "
            f"b.install({name!r}); from app.cli import main; sys.exit(main())")
    try:
        args = [sys.executable, "-c", hook, "run", config, "--out", str(out), "--quiet"]
        for s in sets:
            args += ["--set", s]
        res = subprocess.run(args, cwd=ROOT, env=ENV, capture_output=True, text=True)
        if res.returncode:
            raise RuntimeError(res.stderr.strip()[-300:])
        c = read_pairs(last_step_file(out), index, ("x", "p"))
        on = c["p"] > 0
        return (round(100 * float(local_fit_deviation(c["x"][on], c["p"][on]).max()), 2),
                round(float(c["p"].max()), 1))
    finally:
        shutil.rmtree(out, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kernels", nargs="+", choices=list(KERNELS), default=list(KERNELS))
    ap.add_argument("--block2-sizes", type=float, nargs="+",
                    default=[0.08, 0.12, 0.1, 0.09, 0.07, 0.06, 0.05])
    a = ap.parse_args()
    smooth = 'interface.indent.discretisation="mortar-smooth"'
    for name in a.kernels:
        install(name)
        row = {"kernel": name} | curve_checks()
        for size in a.block2_sizes:
            row[f"multibody_{size:g}"] = run(name, "configs/multibody.toml",
                                             [smooth, f"body.block2.size={size}"], 2)
        row["indent"] = run(name, "configs/indent.toml", [smooth], 0)
        row["indent_mu0"] = run(name, "configs/indent.toml", [smooth, "interface.indent.mu=0.0"],
                                0)
        print(json.dumps(row), flush=True)
        mortar_smooth.smooth_kernel, mortar_smooth.smooth_weights = SHIPPED, _SHIPPED_WEIGHTS


_SHIPPED_WEIGHTS = mortar_smooth.smooth_weights

if __name__ == "__main__":
    main()
