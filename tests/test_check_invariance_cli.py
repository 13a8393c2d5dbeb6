"""scripts/check_invariance.py refuses what it cannot use before any run: before, a bad
--xf item (`mirror_x`) or a missing CONFIG stopped with a traceback (ValueError,
FileNotFoundError), the bad --xf only after the identity run."""

from __future__ import annotations

import subprocess
import sys

import pytest
from support import CONFIGS, ROOT


def _cli(tmp_path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "scripts" / "check_invariance.py"),
                           *args, "--out", str(tmp_path / "inv")], capture_output=True,
                          text=True, timeout=300, cwd=ROOT)


@pytest.mark.parametrize("xf, words", [("mirror_x", "'mirror_x' is not KEY=VALUE"),
                                       ("angle=abc", "the values must be numbers"),
                                       ("shift=5", "shift=X:Y"),
                                       ("scale=-2", "must be positive")])
def test_a_bad_transform_is_an_error_before_any_run(tmp_path, xf, words):
    res = _cli(tmp_path, str(CONFIGS / "patch.toml"), "--xf", "angle=90", xf)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith(f"check_invariance.py: error: --xf {xf}: ") and words in last
    assert not (tmp_path / "inv").exists()


def test_a_missing_config_is_an_error(tmp_path):
    res = _cli(tmp_path, str(tmp_path / "no_such.toml"))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "No such file or directory" in res.stderr.strip().splitlines()[-1]


def test_a_roller_the_transform_cannot_turn_is_an_error_before_any_run(tmp_path):
    """patch.toml's rollers with the default --xf (angle=30 first): before, the identity
    run went ahead and the script stopped with a bare line, exit 1."""
    res = _cli(tmp_path, str(CONFIGS / "patch.toml"))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert res.stderr.strip().splitlines()[-1] == (
        "check_invariance.py: error: --xf angle=30: the roller on lower_sides cannot be "
        "turned by 30 deg (only by multiples of 90)")
    assert not (tmp_path / "inv").exists()
