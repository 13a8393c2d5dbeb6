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
