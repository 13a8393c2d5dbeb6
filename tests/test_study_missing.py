"""An interrupted study's tables list the runs that did not complete
(app/studies/missing_runs.py)."""

from __future__ import annotations

import json
import subprocess

from signal_support import run_script, stop_in_run
from support import CONFIGS, read_csv

from app.studies.missing_runs import (
    level_tag,
    missing_combinations,
    missing_runs,
    planned_runs,
)


def _study_stopped_in_its_third_run(out) -> subprocess.CompletedProcess:
    """cantilever.toml's study at levels 0 and 1 with 4SD and FEM-Q4, Ctrl-C in its third
    run (level 1's first): exit 130."""
    res = run_script(stop_in_run(3), ["study", str(CONFIGS / "cantilever.toml"), "--levels",
                                      "2", "--methods", "4,q4", "--out", str(out), "--quiet"])
    assert res.returncode == 130, res.stderr
    return res


def test_planned_runs_follow_the_study_loop():
    assert planned_runs(1, 3, 1, ["2SD", "4SD"], "4SD") == [
        (1, "2SD"), (1, "4SD"), (2, "2SD"), (2, "4SD"), (3, "4SD")]


def test_missing_runs_name_the_interrupted_and_the_unstarted(tmp_path):
    (tmp_path / "L1_4SD").mkdir()
    (tmp_path / "L1_4SD" / "summary.json").write_text(json.dumps({"status": "interrupted"}))
    plan = planned_runs(0, 1, 0, ["4SD", "FEM-Q4"], "4SD")
    lines = missing_runs(tmp_path, plan, {(0, "4SD")},
                         ["level 0 of 0..1 FEM-Q4: no static equilibrium"], 1)
    assert lines == ["level 1 of 0..1 4SD: interrupted (see L1_4SD/summary.json)",
                     "level 1 of 0..1 FEM-Q4: not run (the study was interrupted)"]


def test_a_level_is_named_by_its_index_and_the_range_run(tmp_path):
    """The progress line read `level 2/2` for the last of `--levels 3` (index over last
    index): now `level 2 of 0..2`, the index of L2_<method> and study.csv's `level`."""
    assert level_tag(2, 0, 2) == "level 2 of 0..2"
    plan = planned_runs(1, 3, 0, ["4SD"], "4SD")  # --first-level 1 --levels 3
    assert missing_runs(tmp_path, plan, {(1, "4SD")}, [], 3) == [
        "level 2 of 1..3 4SD: not run (the study was interrupted)",
        "level 3 of 1..3 4SD: not run (the study was interrupted)"]


def test_an_interrupted_study_lists_what_did_not_complete(tmp_path):
    """The tables of the completed runs read like a study planned that way: nothing said
    that level 1 never ran."""
    out = tmp_path / "s"
    res = _study_stopped_in_its_third_run(out)
    assert "study_tables.md lists the 2 runs that did not complete" in res.stderr
    assert len(read_csv(out / "study.csv")) == 2
    tables = (out / "study_tables.md").read_text()
    assert "- level 1 of 0..1 4SD: not run (the study was interrupted)" in tables
    assert "- level 1 of 0..1 FEM-Q4: not run (the study was interrupted)" in tables


def test_missing_combinations_of_a_sweep(tmp_path):
    from app.studies.sweep import _value

    (tmp_path / "run_001").mkdir()
    (tmp_path / "run_001" / "summary.json").write_text(json.dumps({"status": "interrupted"}))
    combos = [("0.2", "1"), ("0.4", "1"), ("0.6", "1")]
    rows = [{"mu": 0.2, "c": 1.0, "status": "completed", "interface": "a"},
            {"mu": 0.2, "c": 1.0, "status": "completed", "interface": "b"}]
    got = missing_combinations(tmp_path, ["mu", "c"], combos, rows, _value)
    assert [(r["mu"], r["c"], r["status"]) for r in got] == [(0.4, 1.0, "interrupted"),
                                                            (0.6, 1.0, "not run")]


def test_a_study_rerun_into_the_same_folder_ignores_the_earlier_studys_summaries(tmp_path):
    """A second study into the same --out (which reuses its mesh cache) found the first
    study's L1_* summary.json files and listed the runs it never started as "completed"."""
    import os
    import time

    out = tmp_path / "s"
    for name in ("L1_4SD", "L1_FEM-Q4"):
        (out / name).mkdir(parents=True)
        summary = out / name / "summary.json"
        summary.write_text(json.dumps({"status": "completed"}))
        old = time.time() - 3600.0  # written by a study an hour ago
        os.utime(summary, (old, old))
    _study_stopped_in_its_third_run(out)
    tables = (out / "study_tables.md").read_text()
    assert "- level 1 of 0..1 4SD: not run (the study was interrupted)" in tables
    assert "- level 1 of 0..1 FEM-Q4: not run (the study was interrupted)" in tables
    assert "completed (see" not in tables


def test_a_sweeps_missing_combinations_ignore_an_earlier_sweeps_summary(tmp_path):
    import os
    import time

    from app.studies.sweep import _value

    (tmp_path / "run_001").mkdir()
    summary = tmp_path / "run_001" / "summary.json"
    summary.write_text(json.dumps({"status": "completed"}))
    old = time.time() - 3600.0
    os.utime(summary, (old, old))
    rows = [{"mu": 0.2, "status": "completed", "interface": "a"}]
    got = missing_combinations(tmp_path, ["mu"], [("0.2",), ("0.4",)], rows, _value,
                               since=time.time() - 60.0)
    assert [(r["mu"], r["status"]) for r in got] == [(0.4, "not run")]
