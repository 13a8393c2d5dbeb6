"""PETSc's -help passes through to PETSc like every other single-dash option."""

from support import CONFIGS, read_summary, run_cli


def test_petsc_help_is_a_petsc_option(tmp_path):
    """Before, argparse took -help for its -h with the value 'elp': usage lines and
    `argument -h/--help: ignored explicit argument 'elp'`, exit 2."""
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet", "-help"])
    assert res.returncode == 0, res.stderr
    assert "-ksp_type <now preonly" in res.stdout  # PETSc's help of the options in force
    assert read_summary(out)["status"] == "completed"
