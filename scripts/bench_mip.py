"""Benchmark: the mixed-integer search for a complementary basis (`app.lcp.mip`).

Without --run, random dense LCPs (unit diagonal, off-diagonal entries and q standard normal,
seeded) of the sizes given, each searched as the app does (without a caller's check: every
solution is taken). With --run, `python -m app run` in this process on the arguments after
it, with every search of the run recorded. One JSON line per search: its size, the result,
and per bound (`app.lcp.mip.MIP_BOUNDS`) HiGHS's nodes, seconds and seconds per node.

    PYTHONPATH=. .venv/bin/python scripts/bench_mip.py [--sizes 50 100 150 200] [--seed 0]
    PYTHONPATH=. .venv/bin/python scripts/bench_mip.py --run configs/multibody.toml --sd 1 \\
        --mesh-size 1.2 --out /tmp/o --quiet
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import app.lcp.mip as mip  # noqa: E402

RECORD: list[dict] = []


def _recorded_search(*args, **kwargs):
    """`mip._search` timed, its nodes and status added to the last record."""
    t = time.perf_counter()
    res = _SEARCH(*args, **kwargs)
    sec = time.perf_counter() - t
    nodes = int(getattr(res, "mip_node_count", 0) or 0)
    RECORD[-1]["bounds"].append({"status": int(res.status), "nodes": nodes,
                                 "seconds": round(sec, 3),
                                 "s_per_node": round(sec / nodes, 4) if nodes else None})
    return res


_SEARCH = mip._search
mip._search = _recorded_search


def searched(m: np.ndarray, q: np.ndarray, *args, **kwargs):
    """`mip.complementary_basis`, recorded (one JSON line per search)."""
    RECORD.append({"n": int(q.size), "bounds": []})
    t = time.perf_counter()
    basis, words = _BASIS(m, q, *args, **kwargs)
    RECORD[-1].update(found=basis is not None, seconds=round(time.perf_counter() - t, 3),
                      words=words)
    print(json.dumps(RECORD[-1]), file=sys.stderr, flush=True)
    return basis, words


_BASIS = mip.complementary_basis


def main() -> int:
    if "--run" in sys.argv:
        import app.interface.coulomb as coulomb
        from app.cli import main as app_main

        coulomb.complementary_basis = searched
        return app_main(["run", *sys.argv[sys.argv.index("--run") + 1:]])
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[50, 100, 150, 200])
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    bad = [n for n in a.sizes if not 1 <= n <= mip.MIP_MAX_SIZE]
    if bad:
        ap.error(f"--sizes {bad[0]}: a size must be 1 to {mip.MIP_MAX_SIZE} (MIP_MAX_SIZE)")
    rng = np.random.default_rng(a.seed)
    for n in a.sizes:
        m = rng.standard_normal((n, n))
        np.fill_diagonal(m, 1.0)
        searched(m, rng.standard_normal(n))
    return 0


if __name__ == "__main__":
    sys.exit(main())
