"""scripts/field_breakdown.py, floor_orders.py, l2_breakdown.py and mindlin_cycle.py on the
wrong folder or field: one `error:` line and exit 2. Before: a KeyError traceback
('cattaneo') for the default --field q on a Hertz study, and a ValueError (max() of
nothing) for a folder that is not a study."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from support import ROOT


def _cli(script: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "scripts" / script), *args],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)


def _hertz_study(tmp_path):
    (tmp_path / "study.csv").write_text("level,method\n0,4SD\n")
    run = tmp_path / "L0_4SD"
    run.mkdir()
    ref = {"hertz": {"a_hertz": 0.1, "p0_hertz": 5494.0}}
    (run / "summary.json").write_text(json.dumps({"reference": ref, "steps": []}))
    return tmp_path


def _error(res: subprocess.CompletedProcess) -> str:
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ")
    return lines[0]


@pytest.mark.parametrize("script", ["field_breakdown.py", "floor_orders.py"])
def test_field_q_on_a_hertz_study_is_an_error(tmp_path, script):
    line = _error(_cli(script, str(_hertz_study(tmp_path))))
    assert "--field q needs a Cattaneo study" in line and "use --field p" in line


@pytest.mark.parametrize("script", ["field_breakdown.py", "floor_orders.py"])
def test_a_folder_that_is_not_a_study_is_an_error(tmp_path, script):
    assert "is not a study's folder" in _error(_cli(script, str(tmp_path / "nothing")))


def test_a_method_the_study_lacks_is_an_error(tmp_path):
    line = _error(_cli("field_breakdown.py", str(_hertz_study(tmp_path)), "--field", "p",
                       "--reference", "8SD"))
    assert "has no runs of --reference 8SD" in line


def test_l2_breakdown_on_a_folder_that_is_not_a_study_is_an_error(tmp_path):
    """Before: no line and exit 0, as if the study had no levels."""
    res = _cli("l2_breakdown.py", str(tmp_path / "nothing"))
    assert res.returncode == 2 and res.stdout == ""
    assert "is not a study's folder" in res.stderr.strip().splitlines()[-1]
    res = _cli("l2_breakdown.py", str(_hertz_study(tmp_path)), "--method", "8SD")
    assert res.returncode == 2
    assert "has no runs of --method 8SD" in res.stderr.strip().splitlines()[-1]


def test_mindlin_cycle_on_a_missing_folder_is_an_error(tmp_path):
    """Before: a FileNotFoundError traceback."""
    res = _cli("mindlin_cycle.py", str(tmp_path / "nothing"))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "summary.json not found" in res.stderr.strip().splitlines()[-1]


@pytest.mark.parametrize("script, args", [("l2_breakdown.py", []),
                                          ("field_breakdown.py", ["--field", "p"])])
def test_a_run_the_study_did_not_complete_is_left_out(tmp_path, script, args):
    """An interrupted run's folder (summary.json without results, no study.csv row):
    before, l2_breakdown.py ended in a KeyError traceback ('reference') and
    field_breakdown.py took it as the reference run ("has no Hertz reference")."""
    study = _hertz_study(tmp_path)
    run = study / "L1_4SD"
    run.mkdir()
    (run / "summary.json").write_text(json.dumps({"status": "interrupted", "steps": []}))
    (study / "study.csv").write_text("level,method\n")  # neither run has its row
    res = _cli(script, str(study), *args)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    line = res.stderr.strip().splitlines()[-1]  # l2_breakdown.py: argparse's, after usage
    assert "error: " in line and "has no runs of --" in line and "4SD" in line
