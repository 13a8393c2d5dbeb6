"""scripts/check_interrupts.py refuses to signal runs that cannot run: before, no CONFIG
(run as 'None'), a CONFIG that does not exist, or an unknown option passed on to the app
were signalled during start-up, read `interrupted`, and the script exited 0 (all clean)."""

from __future__ import annotations

import subprocess
import sys

from support import ROOT, mpi_env

SCRIPT = ROOT / "scripts" / "check_interrupts.py"


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True,
                          text=True, timeout=300, cwd=ROOT, env=mpi_env())


def _error_line(res: subprocess.CompletedProcess) -> str:
    assert res.returncode == 2, (res.stdout, res.stderr)
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("check_interrupts.py: error: "), res.stderr
    return last


def test_no_config_is_an_error(tmp_path):
    res = _cli("--ranks", "1", "--trials", "1", "--out", str(tmp_path))
    assert "give a CONFIG" in _error_line(res)
    assert res.stdout == ""


def test_a_missing_config_is_an_error(tmp_path):
    res = _cli("configs/no_such.toml", "--ranks", "1", "--trials", "1", "--out", str(tmp_path))
    assert "config file 'configs/no_such.toml' does not exist" in _error_line(res)


def test_a_run_that_fails_unsignalled_stops_before_the_trials(tmp_path):
    res = _cli("configs/patch.toml", "--ranks", "1", "--trials", "1", "--out", str(tmp_path),
               "--bogus-option")
    line = _error_line(res)
    assert "ended 'failed'" in line and "unknown option --bogus-option" in line
    assert res.stdout == "" and not (tmp_path / "trial_0").exists()
