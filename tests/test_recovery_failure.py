"""A failure in rank 0's part of a block solve (the kept columns or the solve with S) ends
a job on several ranks at once: it is shared, the other ranks do not wait in the scatter
that follows it for exit_sync's limit (app/condensation/schur_solver.py)."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest

from tests.support import CONFIGS, ROOT, mpi_env, read_summary

WRAPPER = """
import sys
from app import exit_sync
from app.condensation import contact_columns
exit_sync.RANK0_SECONDS = exit_sync.OTHER_SECONDS = 300.0  # unshared: the job waits
def apply(self, lam):
    raise RuntimeError("injected failure in the kept columns")
contact_columns.ContactColumns.apply = apply
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


def test_rank0_failure_in_the_recovery_is_shared(tmp_path):
    mpiexec = shutil.which("mpiexec")
    if mpiexec is None:
        pytest.fail("mpiexec not found: install openmpi-bin (scripts/setup.sh does)")
    script = tmp_path / "wrapper.py"
    script.write_text(WRAPPER)
    out = tmp_path / "out"
    cmd = [mpiexec, "-n", "2", sys.executable, str(script), "run",
           str(CONFIGS / "hertz.toml"), "--out", str(out)]
    try:  # before: rank 1 waited in the scatter, rank 0 in exit_sync's barrier (300 s)
        proc = subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                              timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail("rank 0's failure in the recovery was not shared: the job waited")
    assert proc.returncode != 0
    assert "injected failure in the kept columns" in proc.stderr
    summary = read_summary(out)
    assert summary["status"] == "failed"
    assert "injected failure" in summary["error"]
