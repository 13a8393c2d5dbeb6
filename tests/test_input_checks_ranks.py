"""The command line's checks (app/cli.py `check_run_input`) are judged by rank 0 and its
verdict is every rank's: a check that reads the file system could pass on a rank that came
later, once rank 0, failing, had made OUT to record that; that rank went on into the run
alone and the job hung (the same as -log_view, tests/test_log_view_file.py)."""

import shutil
import subprocess
import sys

from support import ROOT, mpi_env, read_summary

LATE_RANK = """
import os, runpy, sys, time
import app.cli as cli
check = cli.check_run_input
def late(*args, **kwargs):  # every rank but 0 checks after rank 0 failed and made OUT
    if os.environ.get("OMPI_COMM_WORLD_RANK", "0") != "0":
        time.sleep(3.0)
    return check(*args, **kwargs)
cli.check_run_input = late
sys.argv = ["app", *sys.argv[1:]]
runpy.run_module("app", run_name="__main__")
"""
"""The app with its ranks other than 0 late to the command line's checks."""


def test_a_mesh_file_under_out_is_judged_alike_on_every_rank(tmp_path):
    """mesh.file `OUT/../punch.msh` with OUT not there yet, split (--refine 1: the check
    reads it): rank 0 cannot look it up and makes OUT to record that; before, rank 1,
    checking later, read it and went on into the run alone: the job hung."""
    out = tmp_path / "a" / "o"
    out.parent.mkdir()
    shutil.copy(ROOT / "meshes" / "punch.msh", out.parent / "punch.msh")
    config = tmp_path / "punch.toml"
    config.write_text((ROOT / "meshes" / "punch.toml").read_text().replace(
        'file = "punch.msh"', f'file = "{out}/../punch.msh"'))
    try:
        res = subprocess.run(["mpiexec", "--allow-run-as-root", "-n", "2", sys.executable,
                              "-c", LATE_RANK, "run", str(config), "--out", str(out),
                              "--quiet", "--refine", "1", "--set", "analysis.steps=1"],
                             cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                             timeout=60)
    except subprocess.TimeoutExpired:
        raise AssertionError("the job hung: ranks disagreed on the input") from None
    assert res.returncode == 2, res.stderr
    assert res.stderr.startswith("error: mesh file") and "Traceback" not in res.stderr
    assert read_summary(out)["status"] == "failed"


SMALL_NODE = """
import os, runpy, sys
import app.driver.model as model
if os.environ.get("OMPI_COMM_WORLD_RANK", "0") != "0":  # rank 1 on a node of 1 kB
    model.machine_memory = lambda: 1e3
sys.argv = ["app", *sys.argv[1:]]
runpy.run_module("app", run_name="__main__")
"""
"""The app with its ranks other than 0 on a machine of 1 kB of memory (another node)."""


def test_the_dense_contact_memory_check_is_rank_0s_on_every_rank(tmp_path):
    """The dense contact block's memory check (app/driver/model.py) read each rank's
    machine: on nodes of different memory a rank refused alone while rank 0 went on.
    Rank 0's machine judges (as the size check of the command line)."""
    from support import CONFIGS

    out = tmp_path / "o"
    try:
        res = subprocess.run(["mpiexec", "--allow-run-as-root", "-n", "2", sys.executable,
                              "-c", SMALL_NODE, "run", str(CONFIGS / "patch.toml"), "--out",
                              str(out), "--quiet"], cwd=ROOT, env=mpi_env(),
                             capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        raise AssertionError("the job hung: ranks disagreed on the memory check") from None
    assert res.returncode == 0, res.stderr
    assert read_summary(out)["status"] == "completed"


def _mpmd(folders: list, args: list[str]) -> subprocess.CompletedProcess:
    """`python -m app ARGS` on one rank per folder, each started in its folder (-wdir):
    ranks whose file systems differ, as on nodes without a shared one."""
    cmd = ["mpiexec", "--allow-run-as-root"]
    for i, folder in enumerate(folders):
        cmd += ([":"] if i else []) + ["-n", "1", "-wdir", str(folder), sys.executable,
                                       "-m", "app", *args]
    try:
        return subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                              timeout=90)
    except subprocess.TimeoutExpired:
        raise AssertionError("the job hung: ranks disagreed on the input") from None


def test_out_is_judged_by_rank_0(tmp_path):
    """A relative --out that is a file where rank 1 starts, a new folder where rank 0
    does: before, rank 1 refused alone (`(rank 1; the other ranks did not fail)`), rank 0
    went into the run, and the job ended 35 s later, exit 2, OUT/summary.json `running`.
    Only rank 0 writes into OUT: its verdict is every rank's, both ways."""
    from support import CONFIGS

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (b / "o").write_text("rank 1's file")
    args = ["run", str(CONFIGS / "patch.toml"), "--out", "o", "--quiet", "--mesh-size", "0.5"]
    res = _mpmd([a, b], args)
    assert res.returncode == 0, res.stderr
    assert read_summary(a / "o")["status"] == "completed"
    assert (b / "o").read_text() == "rank 1's file"
    res = _mpmd([b, a], args)  # now rank 0's --out is the file: refused, once
    assert res.returncode == 2
    errors = [ln for ln in res.stderr.splitlines() if ln.startswith("error:")]
    assert errors == ["error: --out o exists and is not a folder"], res.stderr


def test_history_file_is_judged_by_rank_0(tmp_path):
    """`-history sub/h.txt` (PETSc writes it on rank 0 only) with `sub` only where rank 0
    starts: before, rank 1 refused alone before PETSc started, printing nothing, and the
    job was aborted, exit 2, with no summary.json."""
    from support import CONFIGS

    a, b = tmp_path / "a", tmp_path / "b"
    (a / "sub").mkdir(parents=True)
    b.mkdir()
    out = tmp_path / "o"
    res = _mpmd([a, b], ["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                         "--mesh-size", "0.5", "-history", "sub/h.txt"])
    assert res.returncode == 0, res.stderr
    assert read_summary(out)["status"] == "completed"
    assert (a / "sub" / "h.txt").stat().st_size > 0 and list(b.iterdir()) == []


def test_the_config_file_is_read_by_rank_0(tmp_path):
    """A relative config path with the file only where rank 0 starts (nodes without a
    shared file system): before, rank 1 refused alone (`config file 'c.toml' does not
    exist (rank 1; the other ranks did not fail)`) and the job ended 35 s later, exit 2,
    with OUT/summary.json still `running`. Rank 0 reads it and every rank parses its
    text; without it on rank 0, one line, exit 2, summary.json `failed`."""
    from support import CONFIGS

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "c.toml").write_text((CONFIGS / "patch.toml").read_text())
    args = ["run", "c.toml", "--out", "o", "--quiet", "--mesh-size", "0.5",
            "--set", "analysis.steps=1"]
    res = _mpmd([a, b], args)
    assert res.returncode == 0, res.stderr
    summary = read_summary(a / "o")
    assert summary["status"] == "completed" and len(summary["steps"]) == 1
    assert list(b.iterdir()) == []
    res = _mpmd([b, a], args)  # now rank 0 has no c.toml: refused, once, recorded
    assert res.returncode == 2
    errors = [ln for ln in res.stderr.splitlines() if ln.startswith("error:")]
    assert errors == ["error: config file 'c.toml' does not exist"], res.stderr
    summary = read_summary(b / "o")
    assert summary["status"] == "failed" and "c.toml" in summary["error"]
