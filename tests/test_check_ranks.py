"""scripts/check_ranks.py: the comparison of two output folders of the same scene."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys

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


def test_per_pair_law_figures_are_round_off_figures(tmp_path):
    """`kkt_pairs` (its figures, the worst pair's index and interface) differs between
    rank counts with round-off: judged against --roundoff, not compared (before it was
    added, the worst pair's index was an integer that had to be equal)."""
    a = {"steps": [{"kkt_pairs": {"normal": 1e-15, "pair": 3, "interface": "lower",
                                  "by_interface": {"lower": {"normal": 1e-15}}}}]}
    b = {"steps": [{"kkt_pairs": {"normal": 4e-16, "pair": 7, "interface": "upper",
                                  "by_interface": {"lower": {"normal": 4e-16}}}}]}
    diffs, mism = check_ranks.compare_summaries(a, b, 1e-7)
    assert mism == [] and diffs == {}
    bad = {"steps": [{"kkt_pairs": {"normal": 1e-3, "pair": 3, "interface": "lower",
                                    "by_interface": {"lower": {"normal": 1e-3}}}}]}
    _, mism = check_ranks.compare_summaries(a, bad, 1e-7)
    assert any("kkt_pairs/normal = 0.001 above round-off" in m for m in mism)


def _study(path, mu_rows: list[tuple[str, float, float]], run_fy: float):
    """A sweep's output: summary.json, sweep.csv (status, a figure, a wall time) and one
    run folder; an error message names the sweep's own folder."""
    path.mkdir()
    lines = ["mu,status,error,normal_force,t_total"]
    lines += [f"{mu},{st},{'nan' if st == 'completed' else 'failed in ' + str(path)},{f},{t}"
              for mu, (st, f, t) in zip(("0.0", "0.5"), mu_rows, strict=True)]
    (path / "sweep.csv").write_text("\n".join(lines) + "\n")
    (path / "summary.json").write_text(json.dumps(
        {"status": "completed", "end_time": str(run_fy), "runs": 2}))
    _folder(path / "run_000", run_fy, 0.0, 1.0, 1)


def test_studies_compare_tables_runs_and_ignore_times_and_folders(tmp_path):
    _study(tmp_path / "a", [("failed", 1.0, 0.1), ("completed", 2.0, 0.2)], 100.0)
    _study(tmp_path / "b", [("failed", 1.0, 9.0), ("completed", 2.0 + 1e-14, 5.0)], 100.0)
    diffs, mism = check_ranks.compare_study(tmp_path / "a", tmp_path / "b")
    assert mism == [] and max(diffs.values()) < 1e-13  # t_total, end_time, OUT not compared
    assert "sweep.csv:normal_force" in diffs and "sweep.csv:t_total" not in diffs
    _study(tmp_path / "c", [("completed", 1.0, 0.1), ("completed", 2.5, 0.2)], 101.0)
    diffs, mism = check_ranks.compare_study(tmp_path / "a", tmp_path / "c")
    assert diffs["sweep.csv:normal_force"] == 0.2
    assert diffs["run_000/summary:steps/reactions/base/Fy"] > 9e-3
    assert any("sweep.csv:status row 0" in m for m in mism)
    assert check_ranks.headline(diffs)["table"] == 0.2


def test_a_job_that_hangs_or_fails_without_its_line_is_reported(tmp_path):
    done = check_ranks.subprocess.CompletedProcess
    assert check_ranks.job_problems(done([], 0, "", "")) == []
    assert check_ranks.job_problems(done([], 2, "", "error: x\n")) == []
    assert check_ranks.job_problems(done([], None, "", "")) == [
        "no exit within the timeout (hang)"]
    assert check_ranks.job_problems(done([], 1, "", "Traceback (most recent call last)\n")) \
        == ["traceback on stderr", "exit 1 with 0 'error:' lines"]
    assert check_ranks.job_problems(done([], 2, "", "error: x\nerror: x\n")) == [
        "exit 2 with 2 'error:' lines"]
    res = check_ranks.run(ROOT / "configs" / "patch.toml", [], 2, tmp_path / "o", 0.05)
    assert res.returncode is None  # ended by the timeout: mpiexec's process group killed


def test_linked_and_own_copies_of_equal_data_compare_equal(tmp_path):
    """A step array equal to the step before is a link to that copy; a round-off
    difference decides whether it is, and the two runs still agree (before, the linked
    dataset was missing from one run and the XDMF text differed)."""
    from app.output.links import LINK_MIN_BYTES

    m = LINK_MIN_BYTES // 8 + 1
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    for name, bump in (("a", False), ("b", True)):
        w = ResultWriter(tmp_path / name, pts, np.array([[0, 1, 2, 3]]), np.zeros(1, np.int64))
        for step in (1, 2):
            p = np.linspace(1.0, 2.0, m)
            p = np.nextafter(p, 3.0) if bump and step == 2 else p  # one unit in the last place
            contact = {"position": np.zeros((m, 2)) + [0.5, 0.0], "p": p}
            w.write_step(step, float(step), {"displacement": np.zeros((4, 3))},
                         {"stress": np.ones((1, 4))}, contact)
        steps = [{"step": k, "reactions": {"base": {"Fy": 1.0}}} for k in (1, 2)]
        (tmp_path / name / "summary.json").write_text(json.dumps(
            {"status": "completed", "steps": steps}))
    diffs, mism = check_ranks.compare_outputs(tmp_path / "a", tmp_path / "b")
    assert mism == [] and diffs["step:contact/p"] < 1e-15
    assert "contact/p" in check_ranks.h5_datasets(tmp_path / "a" / "step_0002.h5")


def _compare(*folders) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(ROOT / "scripts" / "check_ranks.py"), "--compare",
         *map(str, folders)], capture_output=True, text=True, timeout=120)


def test_two_trees_of_outputs_compare_every_run_by_relative_path(tmp_path):
    """`--compare A B` on two folders of runs (no summary.json at their top): before, a
    traceback (FileNotFoundError on A/summary.json); now every output below is compared
    with the one at the same relative path, one JSON line each, and a run found in one
    tree only is named."""
    for tree in ("a", "b"):
        _folder(tmp_path / tree / "hard" / "shear_off", 100.0, 1e-13, 1.0, 1)
        _folder(tmp_path / tree / "pull_off", 50.0, 0.0, 2.0, 1)
    res = _compare(tmp_path / "a", tmp_path / "b")
    rows = [json.loads(x) for x in res.stdout.splitlines()]
    assert res.returncode == 0 and res.stderr == ""
    assert [r["ref"] for r in rows] == [str(tmp_path / "a" / x)
                                        for x in ("hard/shear_off", "pull_off")]
    assert all(r["verdict"] == "ok" for r in rows)
    _folder(tmp_path / "c" / "hard" / "shear_off", 101.0, 1e-13, 1.0, 1)  # differs
    _folder(tmp_path / "c" / "bonded", 50.0, 0.0, 2.0, 1)  # pull_off missing, bonded new
    res = _compare(tmp_path / "a", tmp_path / "c")
    rows = [json.loads(x) for x in res.stdout.splitlines()]
    assert res.returncode == 1
    assert rows[0]["verdict"] == "DIFFERENT" and rows[0]["ref"].endswith("hard/shear_off")
    assert rows[1]["only_in"] == {str(tmp_path / "a"): ["pull_off"],
                                  str(tmp_path / "c"): ["bonded"]}


def test_compare_of_what_is_no_output_is_one_error_line(tmp_path):
    """Folders with no output below, a missing folder, or a run against a tree: exit 2 and
    one `error:` line naming what --compare expects, no traceback."""
    (tmp_path / "empty1").mkdir()
    (tmp_path / "empty2").mkdir()
    _folder(tmp_path / "run", 1.0, 0.0, 1.0, 1)
    _folder(tmp_path / "tree" / "run", 1.0, 0.0, 1.0, 1)
    for pair, what in [(("empty1", "empty2"), "no summary.json below"),
                       (("empty1", "nowhere"), "nowhere is not a folder"),
                       (("tree", "run"), "is an output (summary.json at its top) but")]:
        res = _compare(*(tmp_path / x for x in pair))
        lines = res.stderr.splitlines()
        assert res.returncode == 2 and res.stdout == "" and len(lines) == 1
        assert lines[0].startswith("error: --compare ") and what in lines[0]
        assert "output folders (each with summary.json)" in lines[0]


def test_two_failed_folders_that_agree_read_failed_alike(tmp_path):
    """--compare of two outputs that failed alike: before, `ok`."""
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        (tmp_path / name / "summary.json").write_text(json.dumps(
            {"status": "failed", "error": "x is wrong", "config": "configs/patch.toml",
             "steps": []}))
    res = subprocess.run([sys.executable, str(ROOT / "scripts" / "check_ranks.py"),
                          "--compare", str(tmp_path / "a"), str(tmp_path / "b")],
                         capture_output=True, text=True, timeout=120, cwd=ROOT)
    row = json.loads(res.stdout)
    assert res.returncode == 1 and row["verdict"] == "FAILED ALIKE"
    assert row["error"] == "x is wrong"
    hourglass = {"status": "failed", "config": "/x/configs/hard/hourglass_1sd.toml",
                 "error": "body 'block' has hourglass modes ..."}
    assert check_ranks.failed_alike(hourglass) == {"expected_failure": hourglass["error"]}
    assert check_ranks.failed_alike(hourglass, ["--sd", "1"])["verdict"] == "FAILED ALIKE"
    assert check_ranks.failed_alike({"status": "completed"}) == {}


def test_the_app_argparse_line_counts_as_its_error_line():
    done = check_ranks.subprocess.CompletedProcess
    text = "usage: python -m app [-h] {run,study} ...\npython -m app: error: unknown option\n"
    assert check_ranks.job_problems(done([], 2, "", text)) == []
