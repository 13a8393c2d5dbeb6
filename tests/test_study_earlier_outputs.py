"""A study into the OUT of an earlier study (app/output/out_owner.earlier_study): the
earlier study's files and run folders go, so OUT holds this study's results only. Before,
`study --levels 2 --methods 4` into the OUT of `--levels 3 --methods 4,q4` left L2_4SD,
L0-L2_FEM-Q4 and the earlier richardson.csv (a Richardson limit this study does not
have) beside its own, and scripts/field_breakdown.py took the stale L2_4SD as its
reference run."""

from __future__ import annotations

import json

from support import CONFIGS, read_csv, read_summary, run_cli

from app.output.out_owner import earlier_study

RUN = json.dumps({"config": "c.toml", "n_steps": 1, "steps": [], "status": "completed"})
"""A run's summary.json as this tool writes it (app/run.py's keys), without the folder
it was written into (as a copy of unknown origin)."""


def _run(folder) -> str:
    """A study run's summary.json written into `folder` (provenance `out`, app/run.py)."""
    return json.dumps({**json.loads(RUN), "provenance": {
        "argv": ["app", "study"], "out": str(folder.resolve())}})


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
        (out / run / "summary.json").write_text(_run(out / run))
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


def _folder(path, summary: str, *extra: str):
    """A folder named like a run with `summary` and the files `extra`."""
    path.mkdir(parents=True)
    (path / "summary.json").write_text(summary)
    for name in extra:
        (path / name).write_text("mine")
    return path


def test_the_users_folders_and_files_survive_the_clearing(tmp_path):
    """What the clearing must leave: a folder of another tool whose summary.json has a
    `status`, a whole earlier study the user keeps under a run's name, the user's own
    files inside a run's folder, a running run's folder (its lock held) and a symlink to
    a folder elsewhere. Before, all but the symlink went with shutil.rmtree."""
    import fcntl
    import os

    from app.studies.batch_status import clear_earlier_study

    out = tmp_path / "o"
    _folder(out, _run(out))
    _folder(out / "L2_4SD", json.dumps({"status": "ok", "tool": "other"}), "results.csv")
    _folder(out / "L1_fine", json.dumps({"command": "study", "study": "convergence",
                                         "config": "c.toml", "status": "completed"}),
            "study.csv")
    _folder(out / "L0_4SD", _run(out / "L0_4SD"), "mesh.h5", "step_0001.h5", "my_notes.txt")
    running = _folder(out / "run_001", _run(out / "run_001"), "mesh.h5")
    _folder(tmp_path / "elsewhere", _run(out / "L3_4SD"), "mesh.h5")
    os.symlink(tmp_path / "elsewhere", out / "L3_4SD")
    _folder(out / "L4_4SD", _run(out / "L4_4SD"), "mesh.h5", "step_0001.h5", "results.xdmf")
    with open(running / ".lock", "a") as lock:
        fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        clear_earlier_study(out)
    assert sorted(p.name for p in (out / "L2_4SD").iterdir()) == ["results.csv",
                                                                  "summary.json"]
    assert sorted(p.name for p in (out / "L1_fine").iterdir()) == ["study.csv",
                                                                   "summary.json"]
    assert sorted(p.name for p in (out / "L0_4SD").iterdir()) == ["my_notes.txt"]
    assert sorted(p.name for p in running.iterdir()) == [".lock", "mesh.h5",
                                                         "summary.json"]
    assert sorted(p.name for p in (tmp_path / "elsewhere").iterdir()) == ["mesh.h5",
                                                                          "summary.json"]
    assert not (out / "L4_4SD").exists()  # the earlier study's own run: gone


def test_a_runs_out_keeps_the_users_files_of_a_studys_names(tmp_path):
    """A `run` writes no study files: in a run's OUT (its summary.json, no run folders)
    a sweep_*.png or study.csv is the user's and stays. Before, a study into that OUT
    removed them (OUT held this tool's summary.json)."""
    out = _folder(tmp_path / "o", _run(tmp_path / "o"), "sweep_mine.png", "study.csv", "mesh.h5")
    assert earlier_study(out) == ([], [])
    (out / "summary.json").write_text(json.dumps({"command": "study", "status": "failed",
                                                  "study": "sweep", "config": "c.toml"}))
    assert sorted(p.name for p in earlier_study(out)[0]) == ["study.csv", "sweep_mine.png"]


def test_a_standalone_run_under_a_run_folders_name_stays(tmp_path):
    """`run --out OUT/L1_fine`, then `study --out OUT`: L1_fine is the user's run (its
    provenance says `run`), not an earlier study's; it stays whole. Before, the study
    removed its results."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "cantilever.toml"), "--mesh-size", "1.0", "--quiet",
                   "--out", str(out / "L1_fine")])
    assert res.returncode == 0, res.stderr
    kept = sorted(p.name for p in (out / "L1_fine").iterdir())
    assert "step_0001.h5" in kept
    assert earlier_study(out) == ([], [])
    summary = json.loads((out / "L1_fine" / "summary.json").read_text())
    summary["provenance"]["argv"][1] = "study"  # as a study's run writes it
    (out / "L1_fine" / "summary.json").write_text(json.dumps(summary))
    assert [p.name for p in earlier_study(out)[1]] == ["L1_fine"]


def test_a_study_runs_folder_copied_by_hand_stays_with_a_warning(tmp_path):
    """A study's run folder copied by hand into another study's OUT under a run folder's
    name (`cp -r a/L0_4SD b/L7_kept`; or an earlier version's, that recorded no folder):
    its summary.json is a study run's, but no study wrote it there. Before, the next study
    into b removed its results (mesh.h5, step_NNNN.h5, summary.json: the folder emptied);
    now it stays whole and the study warns, naming it. The study's own earlier run
    folders (their summary.json records them) still go."""
    import shutil

    a, b = tmp_path / "a", tmp_path / "b"
    args = ["study", str(CONFIGS / "cantilever.toml"), "--levels", "1", "--methods", "4",
            "--mesh-size", "1.0", "--quiet", "--out"]
    for out in (a, b):
        res = run_cli([*args, str(out)])
        assert res.returncode == 0, res.stderr
    shutil.copytree(a / "L0_4SD", b / "L7_kept")
    _folder(b / "run_009", RUN, "mesh.h5")  # no folder recorded (an earlier version's)
    (b / "L0_4SD" / "old.h5").write_text("mine")
    kept = sorted(p.name for p in (b / "L7_kept").iterdir())
    res = run_cli([*args, str(b)])
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in (b / "L7_kept").iterdir()) == kept
    assert "step_0001.h5" in kept and (b / "run_009" / "mesh.h5").exists()
    line = [w for w in read_summary(b).get("warnings", []) if w.startswith("kept ")]
    assert len(line) == 1 and "L7_kept, run_009" in line[0], line
    assert "warning: kept L7_kept, run_009" in res.stderr
    assert (b / "L0_4SD" / "old.h5").exists()  # the user's file in the study's own folder
    assert (b / "L0_4SD" / "step_0001.h5").exists()  # written again by this study
