"""A benchmark whose app run fails says why and exits 1: before, bench_bulk.py,
bench_hertz.py and bench_refine.py exited 0 with an `error` row, and on several ranks the
row held mpiexec's banner instead of the app's `error:` line."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from support import ROOT, mpi_env

sys.path.insert(0, str(ROOT / "scripts"))
from app_runner import failure_reason  # noqa: E402

MPIEXEC_TAIL = """error: unknown option --bogus (PETSc options take a single dash)
error: unknown option --bogus (PETSc options take a single dash)
--------------------------------------------------------------------------
mpiexec detected that one or more processes exited with non-zero status, thus causing
the job to be terminated. The first process to do so was:

  Process name: [[24268,1],1]
  Exit code:    2
--------------------------------------------------------------------------"""


def test_the_failure_reason_is_the_apps_error_line_once():
    assert failure_reason(MPIEXEC_TAIL) == ("error: unknown option --bogus (PETSc options "
                                            "take a single dash)")
    assert failure_reason("usage: python -m app run ...\npython -m app run: error: the "
                          "following arguments are required: config\n") == (
        "python -m app run: error: the following arguments are required: config")
    assert failure_reason("Traceback ...\nKeyError: 'x'\n") == "Traceback ...\nKeyError: 'x'"


BOGUS = "python -m app: error: unknown option --bogus (PETSc options take a single dash)"


@pytest.mark.parametrize("script, args, reason", [
    ("bench_hertz.py", ["--mesh-size", "2.0", "--ranks", "2", "--bogus"], BOGUS),
    ("bench_bulk.py", ["--mesh-size", "1.0", "--ranks", "1", "--bogus"], BOGUS),
    ("bench_refine.py", ["--mesh-size", "1.0", "--splits", "1", "--no-gmsh", "--bogus"], BOGUS),
    ("bench_recovery.py", ["--config", "configs/no_such.toml", "--repeat", "1"],
     "error: config file 'configs/no_such.toml' does not exist"),
])
def test_a_failed_run_exits_1_with_the_apps_reason(script, args, reason):
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / script), *args],
                         capture_output=True, text=True, timeout=300, cwd=ROOT,
                         env=mpi_env())
    assert res.returncode == 1, (res.stdout, res.stderr)
    assert json.loads(res.stdout.splitlines()[0])["error"] == reason
