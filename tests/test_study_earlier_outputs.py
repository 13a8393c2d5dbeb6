"""A study into the OUT of an earlier study (app/output/out_owner.earlier_study): the
earlier study's files and run folders go, so OUT holds this study's results only. Before,
`study --levels 2 --methods 4` into the OUT of `--levels 3 --methods 4,q4` left L2_4SD,
L0-L2_FEM-Q4 and the earlier richardson.csv (a Richardson limit this study does not
have) beside its own, and scripts/field_breakdown.py took the stale L2_4SD as its
reference run."""

from __future__ import annotations

import json

from support import CONFIGS, read_csv, run_cli

from app.output.out_owner import earlier_study


def _earlier(out, summary: bool = True) -> None:
    """OUT as an earlier study left it, with the user's own files beside it."""
    out.mkdir()
    if summary:
        (out / "summary.json").write_text(json.dumps({"status": "completed",
                                                      "command": "study"}))
    for name in ("study.csv", "richardson.csv", "energy_bracket.csv", "energy_bracket.png",
                 "sweep_interface_contact_mu.png"):
        (out / name).write_text("old")
    for run in ("L5_4SD", "L2_FEM-Q4", "run_007"):
        (out / run).mkdir()
        (out / run / "summary.json").write_text(json.dumps({"status": "completed"}))
    (out / "L9_mine").mkdir()  # a run folder's name, but no summary.json of this tool
    (out / "L9_mine" / "notes.txt").write_text("mine")
    (out / "notes.txt").write_text("mine")


def test_what_counts_as_an_earlier_study(tmp_path):
    _earlier(tmp_path / "a")
    files, folders = earlier_study(tmp_path / "a")
    assert sorted(p.name for p in files) == [
        "energy_bracket.csv", "energy_bracket.png", "richardson.csv", "study.csv",
        "sweep_interface_contact_mu.png"]
    assert sorted(p.name for p in folders) == ["L2_FEM-Q4", "L5_4SD", "run_007"]
    (tmp_path / "b").mkdir()  # the user's folder with a study.csv of its own: left alone
    (tmp_path / "b" / "study.csv").write_text("mine")
    assert earlier_study(tmp_path / "b") == ([], [])


def test_a_study_clears_an_earlier_studys_outputs(tmp_path):
    out = tmp_path / "o"
    _earlier(out, summary=False)  # killed outright: no summary.json, its runs' folders
    res = run_cli(["study", str(CONFIGS / "cantilever.toml"), "--levels", "1", "--methods",
                   "4", "--mesh-size", "1.0", "--quiet", "--out", str(out)])
    assert res.returncode == 0, res.stderr
    names = sorted(p.name for p in out.iterdir() if p.name != ".lock")
    assert names == ["L0_4SD", "L9_mine", "energy_vs_sd.png", "error_vs_dofs.png",
                     "error_vs_time.png", "mesh_cache", "notes.txt", "study.csv",
                     "study_tables.md", "summary.json"], names
    assert (out / "L9_mine" / "notes.txt").read_text() == "mine"
    assert [r["method"] for r in read_csv(out / "study.csv")] == ["4SD"]
