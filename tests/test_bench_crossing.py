"""scripts/bench_crossing.py: the checks' seconds are read from a hook around the app. A
completed run ends in `app.exit_sync.end_process` (os._exit), past a `finally` after
the app: the hook's line was never printed, and the script stopped in an IndexError."""

from __future__ import annotations

import json
import subprocess
import sys

from support import ROOT, mpi_env


def test_bench_crossing_reports_the_checks_of_a_completed_run():
    res = subprocess.run([sys.executable, "scripts/bench_crossing.py", "--configs",
                          "configs/patch.toml", "--repeat", "1"], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    (row,) = [json.loads(x) for x in res.stdout.splitlines()]
    assert row["config"] == "configs/patch.toml" and "error" not in row
    assert row["steps"] == 1 and 0 < row["checks_s"] < row["total_s"]
