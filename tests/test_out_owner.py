"""A run's --out clean-up touches only this tool's files (app/output/out_owner.py): a
folder whose summary.json is another program's stops the run with a one-line error, and
the start-up signal handler leaves it alone. Before, that summary.json and the files under
the tool's names next to it (mesh.h5, step_NNNN.h5, ...) were removed or replaced."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from support import CONFIGS, ROOT, mpi_env, run_cli

from app.output.out_owner import UnsafeLock, foreign_files, open_lock
from app.output.startup_signals import STALE


def test_foreign_files_by_name_and_summary(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    (tmp_path / "mesh.h5").write_text("x")
    assert foreign_files(tmp_path, STALE) == []  # no summary.json: an earlier run's leftover
    (tmp_path / "summary.json").write_text('{"other": "tool"}')
    assert foreign_files(tmp_path, STALE) == ["mesh.h5", "summary.json"]
    (tmp_path / "summary.json").write_text("not json")
    assert foreign_files(tmp_path, STALE) == ["mesh.h5", "summary.json"]
    (tmp_path / "summary.json").write_text('{"status": "completed", "config": "a.toml"}')
    assert foreign_files(tmp_path, STALE) == []  # an earlier run's: its files are cleared


def test_run_stops_before_it_removes_a_users_files(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "mesh.h5").write_text("the user's")
    (out / "step_0009.h5").write_text("the user's")
    (out / "summary.json").write_text('{"tool": "other"}')
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"])
    assert res.returncode == 2
    assert "error: --out" in res.stderr and "mesh.h5, step_0009.h5, summary.json" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1, res.stderr
    assert (out / "mesh.h5").read_text() == "the user's"
    assert (out / "step_0009.h5").read_text() == "the user's"


def test_run_over_an_earlier_run_still_clears_it(tmp_path):
    out = tmp_path / "o"
    assert run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"]
                   ).returncode == 0
    (out / "step_0042.h5").write_text("stale")
    (out / "notes.txt").write_text("mine")
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet"])
    assert res.returncode == 0, res.stderr
    assert not (out / "step_0042.h5").exists() and (out / "notes.txt").exists()


HOOK = r"""
import signal, sys
import app.cli as cli
orig = cli.check_run_input
def hooked(*a, **k):
    signal.raise_signal(signal.SIGINT)
    return orig(*a, **k)
cli.check_run_input = hooked
sys.exit(cli.main())
"""


def test_sigint_during_startup_leaves_another_programs_summary(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    theirs = json.dumps({"tool": "other", "result": 1})
    (out / "summary.json").write_text(theirs)
    script = tmp_path / "hook.py"
    script.write_text(HOOK)
    res = subprocess.run([sys.executable, str(script), "run", str(CONFIGS / "patch.toml"),
                          "--out", str(out), "--quiet"], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 130, res.stderr
    assert (out / "summary.json").read_text() == theirs


def test_open_lock_never_follows_a_link_nor_opens_a_fifo(tmp_path):
    """OUT/.lock planted as a symbolic link (a shared folder prepared by someone else) or a
    FIFO is refused, and the link's target is neither created nor locked; a plain file, or
    none, is opened. Before, `open(.lock, "a")` created the link's target and a FIFO hung."""

    target = tmp_path / "elsewhere"
    (tmp_path / ".lock").symlink_to(target)
    with pytest.raises(UnsafeLock, match="lock file .lock is a symbolic link"):
        open_lock(tmp_path / ".lock")
    assert not target.exists()
    fifo = tmp_path / "f"
    fifo.mkdir()
    os.mkfifo(fifo / ".lock")
    with pytest.raises(UnsafeLock, match="is not a plain file"):
        open_lock(fifo / ".lock")
    with open_lock(tmp_path / "new.lock") as fh:
        assert not fh.closed and (tmp_path / "new.lock").is_file()


def test_a_run_refuses_a_planted_lock_link_on_1_and_2_ranks(tmp_path):
    """`python -m app run` into an OUT whose .lock is a link: one `error:` line, exit 2,
    nothing created at the link's target, nothing written into OUT."""
    for ranks in (1, 2):
        out = tmp_path / f"o{ranks}"
        out.mkdir()
        target = tmp_path / f"victim{ranks}"
        (out / ".lock").symlink_to(target)
        res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                       "--mesh-size", "0.5"], ranks=ranks, timeout=120)
        assert res.returncode == 2, res.stderr
        errors = [ln for ln in res.stderr.splitlines() if ln.startswith("error:")]
        assert errors == [f"error: --out {out}: its lock file .lock is a symbolic link (a "
                          "run creates a plain file there; it was put there by someone or "
                          "something else): remove it or choose another --out"], res.stderr
        assert not target.exists()
        assert sorted(p.name for p in out.iterdir()) == [".lock"]


def test_dangling_links_under_the_tools_names_are_removed_not_written_through(tmp_path):
    """Links planted in OUT under the tool's names, to files not there yet: before, the
    run wrote mesh.h5, the step files, the XDMF files and summary.json through them,
    outside OUT (their `.tmp` links followed, then renamed into place), and OUT kept the
    links. Now they are removed like an earlier run's files; OUT holds plain files."""
    out = tmp_path / "o"
    out.mkdir()
    names = ["summary.json", "summary.json.tmp", "mesh.h5.tmp", "step_0001.h5.tmp",
             "results.xdmf.tmp", "contact.xdmf.tmp", "step_0001.h5"]
    for name in names:
        (out / name).symlink_to(tmp_path / f"elsewhere_{name}")
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "--mesh-size", "0.5"], timeout=120)
    assert res.returncode == 0, res.stderr
    assert sorted(p.name for p in tmp_path.glob("elsewhere_*")) == []
    assert not any(p.is_symlink() for p in out.iterdir())
    assert json.loads((out / "summary.json").read_text())["status"] == "completed"


def test_an_early_failure_removes_a_planted_link_before_it_writes(tmp_path):
    """The summary of bad input found before PETSc starts (startup_signals.record_failure)
    clears the same way: before, it wrote through a dangling `summary.json.tmp` link."""
    from app.output.startup_signals import record_failure

    (tmp_path / "summary.json.tmp").symlink_to(tmp_path / "elsewhere")
    assert record_failure(tmp_path, "bad input", {"config": "c.toml"}) is None
    assert not (tmp_path / "elsewhere").exists()
    assert not (tmp_path / "summary.json").is_symlink()
    assert json.loads((tmp_path / "summary.json").read_text())["error"] == "bad input"


def test_a_study_removes_links_under_its_names_instead_of_writing_through(tmp_path):
    """Before: a sweep into an OUT holding `run_000 -> elsewhere/r0` (a folder) wrote that
    run's files into elsewhere/r0, `mesh_cache -> elsewhere/mc` its meshes, and a dangling
    `sweep_steps.csv.tmp` link made elsewhere/sweep_steps.csv.tmp."""
    out, elsewhere = tmp_path / "o", tmp_path / "elsewhere"
    out.mkdir()
    (elsewhere / "r0").mkdir(parents=True)
    (elsewhere / "mc").mkdir()
    (out / "run_000").symlink_to(elsewhere / "r0")
    (out / "mesh_cache").symlink_to(elsewhere / "mc")
    for name in ("sweep.csv.tmp", "sweep_steps.csv.tmp"):
        (out / name).symlink_to(elsewhere / name)
    res = run_cli(["study", str(CONFIGS / "patch.toml"), "--sweep",
                   "interface.interface.mu=0.1,0.2", "--out", str(out), "--quiet",
                   "--mesh-size", "0.5"], timeout=300)
    assert res.returncode == 0, res.stderr
    assert sorted(str(p.relative_to(elsewhere)) for p in elsewhere.rglob("*")) == ["mc", "r0"]
    assert not any(p.is_symlink() for p in out.iterdir())
    assert json.loads((out / "run_000" / "summary.json").read_text())["status"] == "completed"
    # a link the user may have made on purpose (run_000 or mesh_cache on another disk) is
    # not removed silently: a warning names each link and its target (before, none)
    line = f"mesh_cache -> {elsewhere / 'mc'}, run_000 -> {elsewhere / 'r0'}"
    assert res.stderr.count("warning: removed the links ") == 1
    assert line in res.stderr and "--out" in res.stderr.split("warning: removed")[1]
    warned = json.loads((out / "summary.json").read_text()).get("warnings", [])
    assert [w for w in warned if w.startswith("removed the links ") and line in w]
