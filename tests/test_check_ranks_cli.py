"""scripts/check_ranks.py refuses what it cannot compare: before, a missing CONFIG failed
alike on 1 and 2 ranks and read `"verdict": "ok"` with exit 0, `--ranks 1` printed nothing
and exited 0. (A missing `--compare` folder, once a FileNotFoundError:
tests/test_check_ranks.py::test_compare_of_what_is_no_output_is_one_error_line.)"""

from __future__ import annotations

import subprocess
import sys

import pytest
from support import ROOT, mpi_env


@pytest.mark.parametrize("args, words", [
    (["configs/no_such.toml", "--ranks", "1", "2"],
     "config file 'configs/no_such.toml' does not exist"),
    (["configs/patch.toml", "--ranks", "1"], "--ranks needs the reference count"),
])
def test_nothing_to_compare_is_an_error(args, words):
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "check_ranks.py"), *args],
                         capture_output=True, text=True, timeout=300, cwd=ROOT, env=mpi_env())
    assert res.returncode == 2 and res.stdout == "", (res.stdout, res.stderr)
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("check_ranks.py: error: ") and words in last
