"""Shared test helpers: run the CLI in a subprocess (optionally under mpiexec -n 2)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = ROOT / "configs"


def mpi_env() -> dict[str, str]:
    env = dict(os.environ)
    env.update(OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               OMPI_MCA_rmaps_base_oversubscribe="1")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def run_cli(args: list[str], ranks: int = 1, timeout: float = 600) -> subprocess.CompletedProcess:
    """Run `python -m app ARGS` (under `mpiexec -n ranks` when ranks > 1)."""
    cmd = [sys.executable, "-m", "app", *args]
    if ranks > 1:
        mpiexec = shutil.which("mpiexec")
        if mpiexec is None:
            pytest.fail("mpiexec not found: install openmpi-bin (scripts/setup.sh does)")
        cmd = [mpiexec, "-n", str(ranks), *cmd]
    return subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                          timeout=timeout)


def read_summary(out: Path) -> dict:
    return json.loads((Path(out) / "summary.json").read_text())
