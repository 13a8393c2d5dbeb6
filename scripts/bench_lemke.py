"""Benchmark `app.lcp.lemke` on random frictional-contact-like LCPs; prints JSON lines.

    .venv/bin/python scripts/bench_lemke.py            # n = 300, 1500, 3000
    .venv/bin/python scripts/bench_lemke.py --large    # also n = 6000
    .venv/bin/python scripts/bench_lemke.py --n 900 --reference   # also time the tableau
    .venv/bin/python scripts/bench_lemke.py --n 1500 3000 6000 --siconos   # side by side
    .venv/bin/python scripts/bench_lemke.py --n 1500 3000 6000 --textbook  # crash vs textbook
    .venv/bin/python scripts/bench_lemke.py --recovery   # LCPs that need the recovery step

Each line also times one dense LU of the final active block (the floor) and the ratio.
"seconds" is the best of --repeat cold calls (default 3; each call starts from scratch) and
the dense LU the best of as many (at least 3), so that a busy machine hurts both alike.

The LCP (n = 3 m unknowns: m normal pressures, m forward and m backward slips) is built
from an SPD compliance C (2m x 2m: normal block first, then tangential) of a 1D elastic
strip: a Laplace kernel (10 / m) exp(-|x_i - x_j| / 0.1) on m equally spaced points for
C_nn and C_tt plus 0.05 I, and a weak antisymmetric coupling for C_nt. With H = C_tt^-1,
A = C_nn - C_nt H C_tn, Bm = C_nt H and D = mu I:

    M = [[A, Bm, -Bm], [D - Bm^T, H, -H], [D + Bm^T, -H, H]],
    q = [gap0, c + s, c - s]

with gap0 partly negative (penetration) and a tangential load s.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import scipy.linalg as sla

from app.lcp import lemke
from app.lcp.cases import near_duplicate_lcp, row_scaled_lcp, strip_contact_lcp


def frictional_lcp(m: int, *, mu: float = 0.3, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(M, q) of a frictional-contact-like LCP with n = 3 m unknowns (see module docstring;
    the case is `app.lcp.cases.strip_contact_lcp`, shared with tests/test_lemke.py)."""
    return strip_contact_lcp(m, mu=mu, seed=seed)


def siconos_lemke(M: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, int, int, float]:
    """Siconos's compiled Lemke (Debian python3-siconos, optional): z, info, pivots, s."""
    import siconos.numerics as sn

    n = q.size
    z, w = np.zeros(n), np.zeros(n)
    opts = sn.SolverOptions(sn.SICONOS_LCP_LEMKE)
    opts.iparam[sn.SICONOS_IPARAM_MAX_ITER] = 50 * n + 100
    t0 = time.perf_counter()
    info = sn.linearComplementarity_driver(sn.LCP(M, q), z, w, opts)
    dt = time.perf_counter() - t0
    return z, int(info), int(opts.iparam[sn.SICONOS_IPARAM_ITER_DONE]), dt


def best_time(f, repeat: int) -> tuple[float, float, object]:
    """Best wall and best CPU (process) seconds of `repeat` calls of f, and f's result."""
    wall = cpu = np.inf
    for _ in range(max(repeat, 1)):
        t0, c0 = time.perf_counter(), time.process_time()
        out = f()
        wall = min(wall, time.perf_counter() - t0)
        cpu = min(cpu, time.process_time() - c0)
    return wall, cpu, out


def dense_lu_seconds(M: np.ndarray, basis: np.ndarray, repeat: int = 3) -> tuple[float, float]:
    """Best of `repeat` timings (wall, CPU) of one dense LU (scipy lu_factor) of M[B, B]:
    the floor of any method that ends by solving on the final active block."""
    idx = np.flatnonzero(basis)
    A = M[np.ix_(idx, idx)]
    wall, cpu, _ = best_time(lambda: sla.lu_factor(A, check_finite=False), repeat)
    return wall, cpu


def run(n: int, reference: bool = False, seed: int = 0, siconos: bool = False,
        textbook: bool = False, repeat: int = 3) -> dict:
    M, q = frictional_lcp(n // 3, seed=seed)
    dt, cpu, res = best_time(lambda: lemke(M, q), repeat)
    lu, lu_cpu = dense_lu_seconds(M, res.basis, max(repeat, 3))
    out = {
        "n": int(q.size),
        "pivots": res.pivots,
        "seconds": round(dt, 4),
        "repeat": repeat,
        "status": res.status,
        "start": res.warm_start,  # "crash": the crash basis solved it, no pivot
        "basic_z": int(res.basis.sum()),
        "refactorizations": res.refactorizations,
        "complementarity": res.complementarity,
        "dense_lu_final_block_seconds": round(lu, 4),
        "ratio_to_dense_lu": round(dt / lu, 2),
        # CPU (process) time: the work, without the waits of a busy machine
        "cpu_seconds": round(cpu, 4),
        "dense_lu_cpu_seconds": round(lu_cpu, 4),
        "cpu_ratio_to_dense_lu": round(cpu / lu_cpu, 2),
    }
    if textbook:  # the textbook cold start (covering vector 1, no crash)
        t0 = time.perf_counter()
        cold = lemke(M, q, crash=False)
        out["textbook_seconds"] = round(time.perf_counter() - t0, 4)
        out["textbook_pivots"] = cold.pivots
        out["max_abs_z_diff_textbook"] = float(np.abs(cold.z - res.z).max())
    if siconos:
        z, info, piv, dt_s = siconos_lemke(M, q)
        out["siconos_seconds"] = round(dt_s, 4)
        out["siconos_pivots"] = piv
        out["siconos_info"] = info  # 0 = solved
        out["speedup_vs_siconos"] = round(dt_s / max(dt, 1e-12), 2)
        out["max_abs_z_diff_siconos"] = float(np.abs(z - res.z).max())
        # identical outcome: both solved, the same active set
        out["same_active_set_as_siconos"] = bool(np.array_equal(z > 0, res.z > 0))
    if reference:
        from app.lcp.lemke import lemke_tableau

        t0 = time.perf_counter()
        ref = lemke_tableau(M, q)
        out["reference_seconds"] = round(time.perf_counter() - t0, 4)
        out["reference_pivots"] = ref.pivots
        out["max_abs_z_diff"] = float(np.abs(ref.z - res.z).max())
    return out


def recovery_sets() -> list[dict]:
    """Totals over LCPs whose first run fails and that `lemke`'s recovery step
    (app/lcp/recovery.py) solves, each from the crash and the textbook start: the 32
    near-duplicate contact LCPs (n = 50, the QP repair) and 20 row-scaled P-matrix LCPs
    (n = 40, the balanced LCP). One line per set: LCPs, solved, pivots, seconds."""
    sets = {"near_duplicate": [near_duplicate_lcp(s, k, ld) for s in range(8)
                               for k in ("matern", "imq") for ld in ("flat", "parabolic")],
            "row_scaled": [row_scaled_lcp(s) for s in range(20)]}
    out = []
    for name, lcps in sets.items():
        solved = pivots = 0
        t0 = time.perf_counter()
        for M, q in lcps:
            for crash in (True, False):
                res = lemke(M, q, crash=crash)
                solved += res.ok
                pivots += res.pivots
        out.append({"set": name, "lcps": 2 * len(lcps), "solved": solved, "pivots": pivots,
                    "seconds": round(time.perf_counter() - t0, 4)})
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--large", action="store_true", help="also n = 6000")
    ap.add_argument("--n", type=int, nargs="*", help="sizes to run (multiples of 3)")
    ap.add_argument("--reference", action="store_true", help="also run the tableau version")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeat", type=int, default=3,
                    help="cold calls timed; the best counts (default 3)")
    ap.add_argument("--textbook", action="store_true",
                    help="also time the textbook cold start (lemke(..., crash=False))")
    ap.add_argument("--siconos", action="store_true",
                    help="also run Siconos's Lemke on the same LCP (apt install python3-siconos)")
    ap.add_argument("--recovery", action="store_true",
                    help="only the LCPs that need lemke's recovery step (totals per set)")
    args = ap.parse_args()
    if args.recovery:
        for line in recovery_sets():
            print(json.dumps(line), flush=True)
        return
    bad = [n for n in args.n or [] if n < 3 or n % 3]
    if bad:  # (n = 31 ran n = 30 under "n": 30; n = 0 was a ZeroDivisionError traceback)
        ap.error(f"--n {bad[0]}: sizes must be positive multiples of 3 (3 unknowns a pair)")
    if args.repeat < 1:
        ap.error(f"--repeat must be >= 1 (got {args.repeat})")
    sizes = args.n or ([300, 1500, 3000] + ([6000] if args.large else []))
    for n in sizes:
        print(json.dumps(run(n, args.reference, args.seed, args.siconos, args.textbook,
                             args.repeat)), flush=True)


if __name__ == "__main__":
    main()
