"""Benchmark: the seconds of the per-step crossing checks (slave nodes without a pair
through the master, master nodes through the slave; app/contact/unpaired.py and
master_penetration.py), against the run's `recovery` phase that holds them and its total.

Runs each scene `--repeat` times with `python -m app run` under a hook that times
`app.driver.contact._crossing_warnings`, and prints one JSON line per scene with the
medians: the checks' seconds (and per step), `recovery` and `total` from summary.json.

    PYTHONPATH=. .venv/bin/python scripts/bench_crossing.py [--configs ...] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import subprocess
import tempfile
from pathlib import Path

from app_runner import ENV, ROOT, app_command, failure_reason

HOOK = """
import atexit, json, sys, time, runpy
import petsc4py
spent = [0.0, 0]
start = petsc4py.init
def init(*a, **k):  # the app's own start first (app.driver.contact would start PETSc)
    start(*a, **k)
    import app.driver.contact as dc
    inner = dc._crossing_warnings
    def timed(*a, **k):
        t = time.perf_counter()
        try:
            return inner(*a, **k)
        finally:
            spent[0] += time.perf_counter() - t
            spent[1] += 1
    dc._crossing_warnings = timed
petsc4py.init = init
# (atexit: also right if the app's fast end, app.exit_sync.end_process, ever applied here)
atexit.register(lambda: print("CROSSING " + json.dumps(spent), file=sys.stderr, flush=True))
sys.argv = ["app", *sys.argv[1:]]
runpy.run_module("app", run_name="__main__")
"""


def one_run(config: str) -> dict:
    """Seconds in the checks, their calls, and the summary's recovery and total."""
    out = Path(tempfile.mkdtemp(prefix="bench_crossing_"))
    try:
        cmd = app_command(["run", config, "--out", str(out), "--quiet"], script=HOOK)
        res = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True)
        if res.returncode != 0:
            return {"error": failure_reason(res.stderr)}
        line = [x for x in res.stderr.splitlines() if x.startswith("CROSSING ")][-1]
        seconds, calls = json.loads(line.split(" ", 1)[1])
        t = json.loads((out / "summary.json").read_text())["timings"]
        return {"checks_s": seconds, "steps": calls, "recovery_s": t["recovery"],
                "total_s": t["total"]}
    finally:
        shutil.rmtree(out, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--configs", nargs="*", default=["configs/cattaneo.toml",
                                                     "configs/mindlin_cycle.toml",
                                                     "configs/multibody.toml"])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    for config in args.configs:
        try:
            (ROOT / config).read_bytes()
        except OSError as exc:
            ap.error(f"config {config}: {exc}")
    for config in args.configs:
        runs = [one_run(config) for _ in range(args.repeat)]
        bad = [r for r in runs if "error" in r]
        if bad:
            print(json.dumps({"config": config, "error": bad[0]["error"]}), flush=True)
            continue
        med = {k: statistics.median(r[k] for r in runs)
               for k in ("checks_s", "recovery_s", "total_s")}
        steps = runs[0]["steps"]
        print(json.dumps({"config": config, "repeat": args.repeat, "steps": steps,
                          "checks_s": round(med["checks_s"], 4),
                          "checks_per_step_ms": round(1e3 * med["checks_s"] / max(steps, 1), 2),
                          "recovery_s": round(med["recovery_s"], 3),
                          "total_s": round(med["total_s"], 3),
                          "checks_over_total": round(med["checks_s"] / med["total_s"], 4)}),
              flush=True)


if __name__ == "__main__":
    main()
