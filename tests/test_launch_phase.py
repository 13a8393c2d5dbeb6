"""The `launch` phase: from the process's start to PETSc's (the interpreter, the imports
before PETSc, PETSc's and MPI's start), before in no phase and not in `total`."""

import subprocess
import sys
import time

from support import CONFIGS, ROOT, mpi_env, read_summary

from app.startup.launch_time import process_start

SLOW_IMPORT = """
import sys, time
time.sleep(0.5)  # a slow interpreter start, before PETSc
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_process_start_is_in_the_past_of_this_process():
    started = process_start()
    assert started is not None and 0.0 <= time.perf_counter() - started <= 3600.0


def test_time_before_petsc_is_the_launch_phase(tmp_path):
    out = tmp_path / "o"
    res = subprocess.run([sys.executable, "-c", SLOW_IMPORT, "run",
                          str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"],
                         cwd=ROOT, env=mpi_env(), capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    t = read_summary(out)["timings"]
    assert t["launch"] >= 0.5 and t["total"] >= t["launch"] + t["startup"] + t["mesh"]
    phases = sum(v for k, v in t.items() if k != "total")
    assert abs(phases - t["total"]) <= 0.05 * t["total"], t
