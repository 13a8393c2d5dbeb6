"""scripts/check_ranks.py: the comparison of two output folders of the same scene."""

from __future__ import annotations

import importlib.util
import json

import numpy as np

from app.output.xdmf import ResultWriter
from tests.support import ROOT

_spec = importlib.util.spec_from_file_location("check_ranks", ROOT / "scripts" / "check_ranks.py")
check_ranks = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(check_ranks)


def _folder(path, fy: float, fx: float, u_scale: float, state: int):
    """A one-step output: summary with a reaction (Fy real, Fx round-off) and a step file."""
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    w = ResultWriter(path, pts, np.array([[0, 1, 2, 3]]), np.zeros(1, dtype=np.int64))
    disp = np.zeros((4, 3))
    disp[:, 1] = -u_scale * np.arange(4)
    contact = {"position": pts[:2], "state": np.array([state, 1]),
               "gap": np.array([1e-17 * u_scale, 0.0]), "p": np.array([1.0, 2.0])}
    w.write_step(1, 1.0, {"displacement": disp}, {"stress": np.ones((1, 4))}, contact)
    summary = {"status": "completed", "timings": {"total": fy},  # timings: not compared
               "steps": [{"step": 1, "reactions": {"base": {"Fx": fx, "Fy": fy}},
                          "kkt": {"gap": 1e-16}}]}
    (path / "summary.json").write_text(json.dumps(summary))


def test_round_off_agrees_and_real_differences_are_found(tmp_path):
    _folder(tmp_path / "a", 100.0, 1e-13, 1.0, 1)
    _folder(tmp_path / "b", 100.0 * (1 + 1e-14), -3e-13, 1.0 + 1e-15, 1)
    diffs, mism = check_ranks.compare_outputs(tmp_path / "a", tmp_path / "b")
    assert mism == [] and max(diffs.values()) < 1e-13  # Fx judged against Fy, gap against u
    _folder(tmp_path / "c", 101.0, 1e-13, 1.001, 2)
    diffs, mism = check_ranks.compare_outputs(tmp_path / "a", tmp_path / "c")
    assert diffs["summary:steps/reactions/base/Fy"] > 9e-3
    assert diffs["step:displacement"] > 9e-4
    assert any("contact/state" in m for m in mism)
    assert "summary:timings/total" not in diffs
