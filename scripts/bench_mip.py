"""Benchmark: the mixed-integer search for a complementary basis (`app.lcp.mip`).

Without --run, random dense LCPs (unit diagonal, off-diagonal entries and q standard normal,
seeded) of the sizes given, each searched as the app does (without a caller's check: every
solution is taken). With --run, `python -m app run` in this process on the arguments after
it, with every search of the run recorded. One JSON line per search: its size, the result,
and per bound (`app.lcp.mip.MIP_BOUNDS`) HiGHS's nodes, seconds and seconds per node.
--dump DIR (before --run) also writes each search's scaled LCP as DIR/search_K.npz (m, q,
widen, and the scaling of `ContactLCP.M_scaled`: rows R D, cols D, ones outside a run; K
from 1 in the run's order) and each `ContactLCP.solve`'s final basis as DIR/solve_K.npy
(K from 1, every solve of the run). --lcp FILE replays one such LCP: Lemke cold (status, pivots,
its largest z / max |q|), with --unscaled also Lemke cold on the unscaled LCP (M, q as the
app forms them: its largest z in the scene's units and its index) and Lemke's check on the
scaled LCP from that basis, then the search with --bounds (x MIP_SCALE x max |q|, the app's
MIP_BOUNDS by default) and --seconds, each basis judged by Lemke's check warm-started from
it (`app.interface.coulomb.ContactLCP._searched`), one JSON line each; with --basis
FILE.npy (a solve's basis of another run, the same LCP's size) Lemke's check from that
basis instead of the search (status, pivots, least w and largest z over max |q|).

    PYTHONPATH=. .venv/bin/python scripts/bench_mip.py [--sizes 50 100 150 200] [--seed 0]
    PYTHONPATH=. .venv/bin/python scripts/bench_mip.py [--dump /tmp/d] --run \\
        configs/multibody.toml --sd 1 --mesh-size 1.2 --out /tmp/o --quiet
    PYTHONPATH=. .venv/bin/python scripts/bench_mip.py --lcp /tmp/d/search_1.npz \\
        [--unscaled] [--bounds 1e4] [--seconds 120] [--basis /tmp/d2/solve_K.npy]
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


DUMP: list[Path] = []
"""The folder of --dump, if given."""

SOLVES: list[int] = []
"""One entry per `ContactLCP.solve` of the run (--dump numbers their bases)."""

SCALING: list[tuple[np.ndarray, np.ndarray]] = []
"""(rows, cols) of the LCP being searched in a run: M_scaled = rows M cols (`_scaled`)."""


def searched(m: np.ndarray, q: np.ndarray, *args, **kwargs):
    """`mip.complementary_basis`, recorded (one JSON line per search; its LCP saved under
    --dump's folder)."""
    RECORD.append({"n": int(q.size), "bounds": []})
    if DUMP:
        widen = kwargs.get("widen")
        RECORD[-1]["file"] = str(DUMP[0] / f"search_{len(RECORD)}.npz")
        rows, cols = SCALING[-1] if SCALING else (np.ones(q.size), np.ones(q.size))
        np.savez(RECORD[-1]["file"], m=m, q=q, rows=rows, cols=cols,
                 widen=np.ones(q.size) if widen is None else widen)
    t = time.perf_counter()
    basis, words = _BASIS(m, q, *args, **kwargs)
    RECORD[-1].update(found=basis is not None, seconds=round(time.perf_counter() - t, 3),
                      words=words)
    print(json.dumps(RECORD[-1]), file=sys.stderr, flush=True)
    return basis, words


_BASIS = mip.complementary_basis


def _scaled(searched_of):
    """ContactLCP._searched with the LCP's scaling kept for --dump."""
    def wrapped(self, res, ms, qs):
        SCALING.append((self.scaling * self.row_scale, self.scaling))
        return searched_of(self, res, ms, qs)
    return wrapped


def _solved(solve):
    """ContactLCP.solve with each answer's basis saved under --dump's folder."""
    def wrapped(self, *args, **kwargs):
        sol = solve(self, *args, **kwargs)
        SOLVES.append(1)
        if sol.basis is not None:
            np.save(DUMP[0] / f"solve_{len(SOLVES)}.npy", sol.basis)
        return sol
    return wrapped


def _from_basis(m: np.ndarray, q: np.ndarray, basis: np.ndarray) -> None:
    """Lemke's check on LCP(m, q) warm-started from `basis`: one JSON line."""
    from app.lcp import lemke

    res = lemke(m, q, basis=basis, cold_start=False)
    top = float(np.abs(q).max())
    line = {"from_basis": res.status, "pivots": int(res.pivots)}
    if res.z is not None:
        line.update(min_w_over_max_q=float((m @ res.z + q).min() / top),
                    max_z_over_max_q=float(res.z.max() / top))
    print(json.dumps(line), file=sys.stderr, flush=True)


def _unscaled(m: np.ndarray, q: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> None:
    """Lemke cold on the unscaled LCP (m / rows / cols, q / rows), then Lemke's check on
    the scaled one from its basis: one JSON line."""
    from app.lcp import lemke

    res = lemke(m / rows[:, None] / cols[None, :], q / rows)
    line = {"unscaled_lemke": res.status, "pivots": int(res.pivots)}
    if res.z is not None and res.status == "solved":
        check = lemke(m, q, basis=res.basis, cold_start=False)
        line.update(max_z=float(res.z.max()), argmax=int(res.z.argmax()),
                    scaled_max_z_over_max_q=float((res.z / cols).max() / np.abs(q).max()),
                    check=check.status, check_pivots=int(check.pivots))
    print(json.dumps(line), file=sys.stderr, flush=True)


def replay(path: Path, bounds: tuple[float, ...], seconds: float, unscaled: bool,
           basis: Path | None) -> None:
    """The LCP that --dump saved in `path`: Lemke cold, then the search (module doc)."""
    from app.lcp import lemke

    d = np.load(path)
    m, q, widen = d["m"], d["q"], d["widen"]
    top = float(np.abs(q).max())
    res = lemke(m, q)
    print(json.dumps({"lemke": res.status, "pivots": int(res.pivots),
                      "max_z_over_max_q": float(res.z.max() / top) if res.z is not None
                      and top > 0 else None}), file=sys.stderr, flush=True)
    if unscaled:
        _unscaled(m, q, d["rows"], d["cols"])
    if basis is not None:
        _from_basis(m, q, np.load(basis))
        return

    def accept(basis: np.ndarray) -> bool:
        return lemke(m, q, basis=basis, cold_start=False).status == "solved"

    searched(m, q, accept, widen=widen, bounds=bounds, seconds=seconds)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[50, 100, 150, 200])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--dump", type=Path, help="folder for each search's LCP (npz)")
    ap.add_argument("--lcp", type=Path, help="an LCP that --dump saved: replay its search")
    ap.add_argument("--bounds", type=float, nargs="+", default=list(mip.MIP_BOUNDS))
    ap.add_argument("--seconds", type=float, default=mip.MIP_SECONDS)
    ap.add_argument("--unscaled", action="store_true", help="with --lcp: Lemke unscaled too")
    ap.add_argument("--basis", type=Path, help="with --lcp: Lemke's check from this basis")
    run = sys.argv.index("--run") if "--run" in sys.argv else len(sys.argv)
    a = ap.parse_args(sys.argv[1:run])
    if a.dump is not None:
        a.dump.mkdir(parents=True, exist_ok=True)
        DUMP.append(a.dump)
    if run < len(sys.argv):
        import app.interface.coulomb as coulomb
        from app.cli import main as app_main

        coulomb.complementary_basis = searched
        coulomb.ContactLCP._searched = _scaled(coulomb.ContactLCP._searched)
        if DUMP:
            coulomb.ContactLCP.solve = _solved(coulomb.ContactLCP.solve)
        return app_main(["run", *sys.argv[run + 1:]])
    if a.lcp is not None:
        if not a.lcp.is_file():
            ap.error(f"--lcp {a.lcp}: no such file (one that --dump wrote)")
        if a.basis is not None and not a.basis.is_file():
            ap.error(f"--basis {a.basis}: no such file (one that --dump wrote)")
        replay(a.lcp, tuple(a.bounds), a.seconds, a.unscaled, a.basis)
        return 0
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
