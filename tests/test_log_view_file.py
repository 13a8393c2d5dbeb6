"""-log_view with a file that cannot be written is refused before the run, in one line;
before, PETSc opened it only at PetscFinalize: the run completed, exit 0, then a 30-line
PETSc error ("Cannot open PetscViewer file") and no log."""

from support import CONFIGS, read_summary, run_cli


def test_unwritable_log_view_file_is_one_line_before_the_run(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "-log_view", f":{tmp_path}/missing/log.txt"])
    assert res.returncode == 2, res.stderr
    assert res.stderr.startswith("error: -log_view") and "PETSC ERROR" not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert read_summary(out)["status"] == "failed"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "-log_view", f":{tmp_path}/log.txt"])
    assert res.returncode == 0 and "Summary of Stages" in (tmp_path / "log.txt").read_text()


def test_log_view_specs_petsc_cannot_write_are_one_line_before_the_run(tmp_path):
    """Before: `-log_view 1` (draw, binary:f, stdout, a bad file mode) completed, exit 0,
    then a 12-line PETSc error at PetscFinalize and no log; `ascii_xml` or
    `ascii_flamegraph` from [petsc] (--set) a segmentation fault, exit 139 (found by
    scripts/fuzz_inputs.py). The same XML log from the command line still works."""
    import pytest

    from app.errors import InputError
    from app.petsc_options import check_log_view_spec

    for bad, needle in [("1", "viewer type is '1'"), ("draw", "viewer type"),
                        ("binary:f.bin", "viewer type"), (":f.txt::bogus", "file mode"),
                        (":f.txt:info_detail", "unknown format"),
                        ("::ascii_xml", "nested log")]:
        with pytest.raises(InputError, match=needle):
            check_log_view_spec({"log_view": bad})
    for good in ("", "ascii", ":f.txt", "ascii:f.txt:ascii_info_detail:append", "::ascii_csv"):
        check_log_view_spec({"log_view": good})
    out = tmp_path / "o"
    for spec in ("1", f":{tmp_path}/log.xml:ascii_xml"):
        res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                       "--set", f'petsc.log_view="{spec}"'])
        assert res.returncode == 2, res.stderr
        assert len(res.stderr.strip().splitlines()) == 1 and "PETSC ERROR" not in res.stderr
        assert read_summary(out)["status"] == "failed"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "-log_view", f":{tmp_path}/log.xml:ascii_xml"])
    assert res.returncode == 0 and "<petscroot>" in (tmp_path / "log.xml").read_text()


LATE_RANK = """
import os, runpy, sys, time
import petsc4py
start = petsc4py.init
def init(*args, **kwargs):  # (app.petsc_options starts PETSc: patched once it started)
    start(*args, **kwargs)
    import app.petsc_options as po
    check = po.check_log_view_file
    def late(config_petsc):  # every rank but 0 checks after rank 0 failed and made OUT
        if os.environ.get("OMPI_COMM_WORLD_RANK", "0") != "0":
            time.sleep(3.0)
        return check(config_petsc)
    po.check_log_view_file = late
petsc4py.init = init
sys.argv = ["app", *sys.argv[1:]]
runpy.run_module("app", run_name="__main__")
"""
"""The app with its ranks other than 0 late to the -log_view file check."""


def test_a_log_view_file_under_out_is_judged_alike_on_every_rank(tmp_path):
    """`-log_view :OUT/../log.txt` with OUT not there yet: the folder OUT/.. cannot be looked
    up, but it can once rank 0, failing on it, has made OUT to record that. Before, a rank
    that checked later passed and went on into the run: a hang until mpiexec was killed
    (exit 1 with tracebacks on some timings). Rank 0's verdict is every rank's."""
    import subprocess
    import sys

    from support import ROOT, mpi_env

    out = tmp_path / "a" / "o"
    res = subprocess.run(["mpiexec", "-n", "2", sys.executable, "-c", LATE_RANK, "run",
                          str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                          "-log_view", f":{out}/../log.txt"], cwd=ROOT, env=mpi_env(),
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert res.stderr.startswith("error: -log_view") and "Traceback" not in res.stderr
    assert read_summary(out)["status"] == "failed"
