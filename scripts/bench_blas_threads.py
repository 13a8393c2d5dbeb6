"""Benchmark: OpenBLAS threads, one a core against one, in turn, end to end.

Runs `python -m app run CONFIG` (under `mpiexec -n RANKS`, with `--bind-to none` for the
`_unbound` cases: every rank may use every core, as under a launcher that does not bind)
once with each setting in turn, `--repeat` rounds, and prints one JSON line per case: for
each setting the medians of summary.json's `total` and `lcp` seconds, every run's total,
and the BLAS threads the runs recorded (`provenance.blas_threads.threads`), then the
ratios of the medians against the first setting. Settings: `cores`
(OPENBLAS_NUM_THREADS = os.cpu_count(): what OpenBLAS starts when nothing is set, on one
rank or unbound), `1` (one thread), `default` (none of OPENBLAS_NUM_THREADS /
OMP_NUM_THREADS / MKL_NUM_THREADS set: the app's choice, app/blas_threads.py).

    PYTHONPATH=. .venv/bin/python scripts/bench_blas_threads.py [--repeat 3]
        [--only cattaneo_1 hertz_0.125_2_unbound] [--settings cores 1 default]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import tempfile
from pathlib import Path

from app_runner import ROOT, app_command, failure_reason

UNBOUND = ["--bind-to", "none"]
CASES = {  # name: (config, the app's extra arguments, ranks, mpiexec's extra arguments)
    "cattaneo_1": ("configs/cattaneo.toml", [], 1, []),
    "cattaneo_2": ("configs/cattaneo.toml", [], 2, []),
    "cattaneo_2_unbound": ("configs/cattaneo.toml", [], 2, UNBOUND),
    "cattaneo_many_1": ("configs/hard/cattaneo_many.toml", [], 1, []),
    "cattaneo_many_2_unbound": ("configs/hard/cattaneo_many.toml", [], 2, UNBOUND),
    "hertz_0.125_1": ("configs/hertz.toml", ["--mesh-size", "0.125"], 1, []),
    "hertz_0.125_2": ("configs/hertz.toml", ["--mesh-size", "0.125"], 2, []),
    "hertz_0.125_2_unbound": ("configs/hertz.toml", ["--mesh-size", "0.125"], 2, UNBOUND),
}
THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


def environment(setting: str) -> dict[str, str]:
    """The run's environment: no thread variable ("default": the app's choice), one BLAS
    thread ("1") or one a core ("cores": what OpenBLAS starts when nothing is set)."""
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARS}
    env |= {"OMPI_ALLOW_RUN_AS_ROOT": "1", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM": "1"}
    if setting != "default":
        env["OPENBLAS_NUM_THREADS"] = "1" if setting == "1" else str(os.cpu_count() or 1)
    return env


def run(config: str, extra: list[str], ranks: int, mpi: list[str], setting: str) -> dict:
    """total and lcp seconds and the recorded BLAS threads of one run."""
    out = Path(tempfile.mkdtemp(prefix="bench_blas_"))
    try:
        cmd = app_command(["run", config, "--out", str(out), "--quiet", *extra], ranks)
        cmd[1:1] = mpi if ranks > 1 else []  # mpiexec's own options first
        res = subprocess.run(cmd, cwd=ROOT, env=environment(setting),
                             capture_output=True, text=True)
        path = out / "summary.json"
        if res.returncode != 0 or not path.exists():
            return {"error": failure_reason(res.stderr)}
        s = json.loads(path.read_text())
    finally:
        shutil.rmtree(out, ignore_errors=True)
    t = s["timings"]
    return {"total": t["total"], "lcp": t.get("lcp", 0.0),
            "blas_threads": s.get("provenance", {}).get("blas_threads", {}).get("threads")}


def compare(name: str, settings: list[str], repeat: int) -> dict:
    """Runs each setting in turn, `repeat` rounds; medians and ratios against the first."""
    config, extra, ranks, mpi = CASES[name]
    runs: dict[str, list[dict]] = {s: [] for s in settings}
    for _ in range(repeat):
        for s in settings:
            runs[s].append(run(config, extra, ranks, mpi, s))
    line: dict = {"case": name, "config": config, "args": extra, "ranks": ranks,
                  "mpiexec_args": mpi, "repeat": repeat}
    for s, rs in runs.items():
        bad = [r["error"] for r in rs if "error" in r]
        if bad:
            line[s] = {"error": bad[0]}
            continue
        line[s] = {"total_s": round(statistics.median(r["total"] for r in rs), 3),
                   "lcp_s": round(statistics.median(r["lcp"] for r in rs), 3),
                   "totals_s": [round(r["total"], 3) for r in rs],
                   "blas_threads": sorted({r["blas_threads"] for r in rs}, key=str)}
    base = line[settings[0]]
    for s in settings[1:]:
        if "error" not in base and "error" not in line[s]:
            line[f"{s}_over_{settings[0]}"] = {
                k: round(line[s][k] / base[k], 3) if base[k] else None
                for k in ("total_s", "lcp_s")}
    return line


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", nargs="*", choices=sorted(CASES), default=None)
    ap.add_argument("--skip", nargs="*", choices=sorted(CASES), default=[])
    ap.add_argument("--settings", nargs="+", default=["cores", "1", "default"],
                    choices=["cores", "1", "default"],
                    help="cores: OPENBLAS_NUM_THREADS = the machine's cores (OpenBLAS's "
                         "own default); 1: one thread; default: none set, the app's choice")
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    for name in args.only or CASES:
        if name not in args.skip:
            print(json.dumps(compare(name, args.settings, args.repeat)), flush=True)


if __name__ == "__main__":
    main()
