"""`study --allow-large` (and with --sweep) reaches each run's dense contact check, as
`run --allow-large` does; before, a study's runs were refused by that check whatever the
option said. The machine's memory is made 1 MB here so that every run is too large."""

import subprocess
import sys

import pytest
from support import CONFIGS, ROOT, mpi_env

TINY_MACHINE = """
import sys
import app.driver.model
app.driver.model.machine_memory = lambda: 1e6
from app.cli import main
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.parametrize("extra", [["--levels", "1", "--methods", "4"],
                                   ["--sweep", "interface.contact.mu=0.1"]],
                         ids=["study", "sweep"])
def test_study_allow_large_reaches_the_dense_check(tmp_path, extra):
    def study(*more):
        cmd = [sys.executable, "-c", TINY_MACHINE, "study", str(CONFIGS / "hertz.toml"),
               "--quiet", *extra, *more]
        return subprocess.run(cmd, cwd=ROOT, env=mpi_env(), capture_output=True, text=True,
                              timeout=300)

    refused = study("--out", str(tmp_path / "a"))
    assert "dense Schur complement" in refused.stderr + (
        (tmp_path / "a" / "sweep.csv").read_text() if (tmp_path / "a" / "sweep.csv").exists()
        else ""), refused.stderr
    allowed = study("--out", str(tmp_path / "b"), "--allow-large")
    assert allowed.returncode == 0, allowed.stderr
    assert "dense Schur complement" not in allowed.stderr
