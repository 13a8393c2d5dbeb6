"""scripts/check_ranks.py refuses what it cannot compare: before, a missing CONFIG failed
alike on 1 and 2 ranks and read `"verdict": "ok"` with exit 0, `--ranks 1` printed nothing
and exited 0. (A missing `--compare` folder, once a FileNotFoundError:
tests/test_check_ranks.py::test_compare_of_what_is_no_output_is_one_error_line.)"""

from __future__ import annotations

import json
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


def test_a_config_outside_the_repository_is_compared(tmp_path):
    """A scene of the user's own, outside the repository, gets its row (the config's
    absolute path); before, every rank ran and then a ValueError of relative_to ended it."""
    cfg = tmp_path / "own.toml"
    cfg.write_text((ROOT / "configs" / "patch.toml").read_text())
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "check_ranks.py"), str(cfg),
                          "--ranks", "1", "2", "--keep", str(tmp_path / "keep")],
                         capture_output=True, text=True, timeout=600, cwd=ROOT, env=mpi_env())
    assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
    (row,) = [json.loads(line) for line in res.stdout.splitlines()]
    assert row["config"] == str(cfg.resolve()) and row["verdict"] == "ok", row


@pytest.mark.parametrize("args, code, verdict, key", [
    (["configs/patch.toml", "--bogus"], 1, "FAILED ALIKE", "error"),
    (["configs/hard/hourglass_1sd.toml"], 0, "ok", "expected_failure"),
])
def test_runs_that_fail_alike_are_no_pass(args, code, verdict, key):
    """Before, both read `"verdict": "ok"`, exit 0: an unknown option failed every run
    alike and the scene passed unchecked. A scene that stops on purpose stays ok."""
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "check_ranks.py"), *args,
                          "--ranks", "1", "2", "--timeout", "120"],
                         capture_output=True, text=True, timeout=300, cwd=ROOT, env=mpi_env())
    assert res.returncode == code, (res.stdout, res.stderr)
    row = json.loads(res.stdout.strip().splitlines()[-1])
    assert row["verdict"] == verdict and row["status"] == ["failed", "failed"]
    assert ("bogus" if key == "error" else "hourglass") in row[key]
