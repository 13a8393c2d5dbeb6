"""Shared by the benchmark scripts: run `python -m app run` (under mpiexec for > 1 rank)
in a temporary output folder and return its summary.json."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")


def app_command(args: list[str], ranks: int = 1, script: str | None = None) -> list[str]:
    """The command line of `python -m app ARGS` (or `python -c SCRIPT ARGS`: the app with a
    hook), under `mpiexec -n ranks` when ranks > 1."""
    head = [sys.executable, "-c", script] if script else [sys.executable, "-m", "app"]
    if ranks > 1:
        return [shutil.which("mpiexec") or "mpiexec", "-n", str(ranks), *head, *args]
    return [*head, *args]


def failure_reason(stderr: str) -> str:
    """The app's `error: ...` line(s) (`python -m app: error: ...` for argparse's) of a failed
    run's stderr (once each, in order), else its last 500 characters. Under mpiexec the
    app's line comes before mpiexec's banner (`... exited with non-zero status ...`),
    which the last 500 characters held alone."""
    lines = [x.strip() for x in stderr.splitlines()
             if re.match(r"(python -m app[\w ]*: )?error: ", x.strip())]
    return "\n".join(dict.fromkeys(lines)) if lines else stderr.strip()[-500:]


def run_app(config: str, args: list[str], ranks: int = 1,
            pairs: tuple[str, ...] = ()) -> dict:
    """Summary of one run, or {"error": last stderr line(s)} when it failed.

    pairs: fields of interface 0's contact pairs (`app.output.read.read_pairs`, e.g.
    ("x", "p")) to read from the run's last step file, returned under the extra key
    `last_step_pairs` (name -> array).
    """
    out = Path(tempfile.mkdtemp(prefix="bench_"))
    try:
        cmd = app_command(["run", config, "--out", str(out), "--quiet", *args], ranks)
        res = subprocess.run(cmd, cwd=ROOT, env=ENV, capture_output=True, text=True)
        if res.returncode != 0:
            return {"error": failure_reason(res.stderr)}
        summary = json.loads((out / "summary.json").read_text())
        if pairs:
            from app.output.read import last_step_file, read_pairs

            summary["last_step_pairs"] = read_pairs(last_step_file(out), 0, pairs)
        return summary
    finally:
        shutil.rmtree(out, ignore_errors=True)
