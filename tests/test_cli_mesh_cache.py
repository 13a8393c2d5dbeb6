"""`--mesh-cache ""` is refused as `--out ""` is (README "Input checks")."""

import subprocess
import sys

import pytest
from support import CONFIGS, mpi_env, read_summary


@pytest.mark.parametrize("value", ["", " "])
def test_an_empty_mesh_cache_is_an_error(tmp_path, value):
    """Before, argparse made Path("") = ".": the run kept its mesh cache in the working
    directory (here tmp_path), exit 0."""
    out = tmp_path / "o"
    res = subprocess.run([sys.executable, "-m", "app", "run", str(CONFIGS / "patch.toml"),
                          "--out", str(out), "--quiet", "--mesh-cache", value],
                         cwd=tmp_path, env=mpi_env(), capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 2, res.stderr
    assert res.stderr.strip() == "error: --mesh-cache is empty: give a folder name"
    assert read_summary(out)["status"] == "failed"
    assert not list(tmp_path.glob("*.npz"))
