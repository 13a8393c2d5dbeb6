"""scripts/hertz_profile.py on a folder it cannot use: one `error:` line, exit 2. Before: a
TypeError traceback from h5py for a missing folder, a KeyError ('hertz') for a run
without the Hertz reference, and no line with exit 0 when given nothing."""

from __future__ import annotations

import json
import subprocess
import sys

from support import ROOT


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "scripts" / "hertz_profile.py"), *args],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)


def _last_error(res: subprocess.CompletedProcess) -> str:
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("hertz_profile.py: error: ")
    return last


def test_a_missing_folder_is_an_error(tmp_path):
    assert "not a run's --out folder" in _last_error(_cli(str(tmp_path / "nothing")))


def test_a_run_without_the_hertz_reference_is_an_error(tmp_path):
    (tmp_path / "summary.json").write_text(json.dumps({"steps": [{"step": 1}]}))
    assert "no Hertz reference" in _last_error(_cli(str(tmp_path)))


def test_nothing_to_do_is_an_error():
    assert "--floor-table" in _last_error(_cli())
