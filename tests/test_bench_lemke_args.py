"""scripts/bench_lemke.py: bad sizes are a usage error (exit 2), not a traceback or a
silently different size."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.support import ROOT, mpi_env

SCRIPT = ROOT / "scripts" / "bench_lemke.py"


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], cwd=ROOT, env=mpi_env(),
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("args", [("--n", "31"), ("--n", "0"), ("--n", "-3"),
                                  ("--n", "30", "--repeat", "0")])
def test_bad_sizes_are_a_usage_error(args):
    res = _run(*args)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    assert res.stderr.strip().splitlines()[-1].startswith("bench_lemke.py: error: --")
    assert res.stdout == ""


def test_small_size_prints_one_json_line():
    res = _run("--n", "30", "--repeat", "1", "--textbook")
    assert res.returncode == 0, res.stderr
    (line,) = res.stdout.splitlines()
    out = json.loads(line)
    assert out["n"] == 30 and out["status"] == "solved"
