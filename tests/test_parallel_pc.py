"""app/assembly/parallel_pc.py: -pc_type icc / ilu on several ranks (block Jacobi)."""

from __future__ import annotations

import json

import pytest

from app.assembly.parallel_pc import block_jacobi_for_sequential_pc
from tests.support import CONFIGS, cleared_petsc_options, run_cli

KEYS = ("pc_type", "sub_pc_type", "pc_factor_levels", "sub_pc_factor_levels",
        "pc_factor_mat_solver_type")


@pytest.fixture
def opts():
    """The PETSc options database with KEYS cleared, restored afterwards."""
    yield from cleared_petsc_options(KEYS)


def test_icc_becomes_block_jacobi_on_several_ranks_only(opts):
    opts.setValue("pc_type", "icc")
    opts.setValue("pc_factor_levels", "1")
    assert block_jacobi_for_sequential_pc(opts, 1) is None
    assert opts.getString("pc_type") == "icc"
    assert block_jacobi_for_sequential_pc(opts, 2) == "icc"
    assert opts.getString("pc_type") == "bjacobi" and opts.getString("sub_pc_type") == "icc"
    assert opts.getString("sub_pc_factor_levels") == "1"
    assert not opts.hasName("pc_factor_levels")


def test_other_preconditioners_are_left_alone(opts):
    for pc in ("lu", "cholesky", "gamg", "bjacobi"):
        opts.setValue("pc_type", pc)
        assert block_jacobi_for_sequential_pc(opts, 4) is None
        assert opts.getString("pc_type") == pc
    opts.setValue("pc_type", "ilu")
    opts.setValue("pc_factor_mat_solver_type", "superlu_dist")  # a parallel ILU: kept
    assert block_jacobi_for_sequential_pc(opts, 4) is None


def test_cg_icc_solves_on_two_ranks_as_on_one(tmp_path):
    """Before: `error: PETSc: Could not locate a solver type for factorization type ICC
    and matrix type mpiaij`, exit 2, on 2 ranks; 1 rank completed."""
    energy = {}
    for ranks in (1, 2):
        out = tmp_path / f"n{ranks}"
        res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--mesh-size", "2.0", "--out",
                       str(out), "--quiet", "-ksp_type", "cg", "-pc_type", "icc"],
                      ranks=ranks, timeout=120)
        assert res.returncode == 0, res.stderr
        energy[ranks] = json.loads((out / "summary.json").read_text())["strain_energy"]
    assert energy[2] == pytest.approx(energy[1], rel=1e-8)
