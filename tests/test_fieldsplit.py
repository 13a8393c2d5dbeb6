"""PCFIELDSPLIT on the stiffness matrix: the DOFs are (x, y) interleaved per node on every
rank, so `pc_fieldsplit_block_size = 2` splits them by component, from [petsc] or the
command line, on 1 and 2 ranks; without it PETSc's `must have at least two fields, not 1`
says what to add (before, only "see the PETSc manual")."""

from __future__ import annotations

import pytest
from support import CONFIGS, read_summary, run_cli

PATCH = str(CONFIGS / "patch.toml")
FIELDSPLIT = ["--set", 'petsc.ksp_type="gmres"', "--set", 'petsc.pc_type="fieldsplit"']


def _energy(out) -> float:
    return read_summary(out)["steps"][-1]["strain_energy"]


@pytest.mark.parametrize("ranks", [1, 2])
def test_fieldsplit_by_component_matches_the_direct_solve(tmp_path, ranks):
    base = ["run", PATCH, "--quiet", "--mesh-size", "0.5"]
    direct = run_cli([*base, "--out", str(tmp_path / "lu")], ranks=ranks, timeout=120)
    assert direct.returncode == 0, direct.stderr
    split = run_cli([*base, "--out", str(tmp_path / "fs"), *FIELDSPLIT, "--set",
                     "petsc.pc_fieldsplit_block_size=2"], ranks=ranks, timeout=120)
    assert split.returncode == 0, split.stderr
    assert _energy(tmp_path / "fs") == pytest.approx(_energy(tmp_path / "lu"), rel=1e-9)


def test_fieldsplit_without_fields_says_what_to_add(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", PATCH, "--quiet", "--mesh-size", "0.5", "--out", str(out),
                   *FIELDSPLIT], timeout=120)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: PETSc: "), res.stderr
    assert "-pc_fieldsplit_block_size 2 splits it into the x and y displacements" in lines[0]
    assert "-pc_fieldsplit_block_size 2" in read_summary(out)["error"]
