"""scripts/check_xdmf.py as a user runs it: --help, a path that is not a run's folder
(before: no line and exit 0, read as "no problem"), a run without its contact.xdmf
(before: skipped without a word)."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys

import numpy as np
from support import ROOT

from app.output.xdmf import ResultWriter

SCRIPT = ROOT / "scripts" / "check_xdmf.py"


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True,
                          text=True, timeout=120, cwd=ROOT)


def _module():
    spec = importlib.util.spec_from_file_location("check_xdmf", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_help_describes_the_script():
    res = _cli("--help")
    assert res.returncode == 0
    assert "Can ParaView read a run's output?" in res.stdout


def test_a_missing_folder_is_an_error_not_a_pass(tmp_path):
    res = _cli(str(tmp_path / "no_such_run"))
    assert res.returncode == 2
    assert res.stdout == ""
    assert res.stderr.strip().splitlines()[-1].startswith("check_xdmf.py: error: ")
    assert "is not a folder" in res.stderr


def test_a_folder_without_output_is_an_error(tmp_path):
    res = _cli(str(tmp_path))
    assert res.returncode == 2
    assert "holds no run output" in res.stderr.strip().splitlines()[-1]


def test_an_unknown_option_is_an_error(tmp_path):
    res = _cli("--bogus", str(tmp_path))
    assert res.returncode == 2
    assert "unrecognized arguments: --bogus" in res.stderr


def test_a_run_with_contact_but_no_contact_xdmf_is_a_problem(tmp_path):
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    w = ResultWriter(tmp_path, pts, np.array([[0, 1, 2, 3]]), np.zeros(1, dtype=np.int64))
    contact = {"position": pts[[2, 3]], "slave": np.array([2, 3]),
               "normal": np.array([[0.0, 1.0], [0.0, 1.0]]),
               "tangent": np.array([[1.0, 0.0], [1.0, 0.0]]), "p": np.array([1.0, 2.0])}
    w.write_step(1, 1.0, {"displacement": np.zeros((4, 3))}, {"stress": np.zeros((1, 4))},
                 contact)
    (tmp_path / "results.xdmf").unlink()
    (tmp_path / "contact.xdmf").unlink()
    rows = list(_module().check(tmp_path))
    assert {r["file"]: r["problems"] for r in rows} == {"results.xdmf": ["missing"],
                                                        "contact.xdmf": ["missing"]}


def test_a_study_folder_stands_for_its_run_folders(tmp_path):
    (tmp_path / "summary.json").write_text(json.dumps({"command": "study", "steps": []}))
    for run in ("L1_4SD", "L0_4SD"):
        (tmp_path / run).mkdir()
        (tmp_path / run / "summary.json").write_text(json.dumps({"status": "completed"}))
    (tmp_path / "mesh_cache").mkdir()
    assert _module().parse_args([str(tmp_path)]).out == [tmp_path / "L0_4SD",
                                                         tmp_path / "L1_4SD"]


def test_compare_xdmf_refuses_a_folder_without_results(tmp_path):
    """Before: every file and reader reported as differing (`times [] vs ...`), exit 1."""
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "results.xdmf").write_text("<Xdmf/>")
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "compare_xdmf.py"),
                          str(tmp_path / "a"), str(tmp_path / "b")], capture_output=True,
                         text=True, timeout=120, cwd=ROOT)
    assert res.returncode == 2 and res.stdout == ""
    assert "has no results.xdmf" in res.stderr.strip().splitlines()[-1]
