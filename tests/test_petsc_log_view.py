"""`log_view` in the config's [petsc] table profiles the run as -log_view does."""

import pytest
from support import CONFIGS, read_summary, run_cli


@pytest.mark.parametrize("value", ["true", '""', '":{log}"'])
def test_log_view_from_the_config(tmp_path, value):
    """Before, PETSc read it too late: after a completed run, a 12-line PETSc error at
    PetscFinalize ("Unsupported viewer true" / "Must use -log_view ..."), no log, and a
    warning that the option was not used."""
    log = tmp_path / "log.txt"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(tmp_path / "o"),
                   "--quiet", "--set", "petsc.log_view=" + value.format(log=log)])
    assert res.returncode == 0, res.stderr
    assert "PETSC ERROR" not in res.stderr and "not used" not in res.stderr, res.stderr
    text = log.read_text() if "log" in value else res.stdout
    assert "lcp" in text and "Summary of Stages" in text
    assert "petsc_options_unused" not in read_summary(tmp_path / "o")
