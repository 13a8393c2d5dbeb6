"""One factorization with the Schur set serves compliance and solves; iterative solvers."""

from __future__ import annotations

import numpy as np
import pytest
from petsc4py import PETSc
from support import CONFIGS, read_summary, run_cli

from app.assembly.loads import constrained_dofs
from app.assembly.solve import LinearSolver, apply_dirichlet, set_default_options
from app.assembly.stiffness import assemble_stiffness
from app.condensation.compliance import (
    attach_schur,
    compliance_from_factor,
    compliance_schur,
    compliance_solve,
    request_schur,
)
from app.condensation.schur_solver import DenseFactor
from app.config import load_config
from app.interface.contact import ContactSetup
from app.interface.floating import floating_modes
from app.run import RunOptions, build_scene_mesh, make_discretisation, to_numpy_all


@pytest.fixture(scope="module")
def hertz():
    """The Hertz scene's Dirichlet-eliminated stiffness, pairs and fixed DOFs."""
    cfg = load_config(CONFIGS / "hertz.toml")
    opts = RunOptions(quiet=True)
    set_default_options(cfg.petsc)
    mesh = build_scene_mesh(cfg, opts)
    disc = make_discretisation(cfg, opts)
    contact = ContactSetup.build(mesh, cfg)
    fixed = constrained_dofs(mesh, cfg)
    floating = floating_modes(mesh, cfg, fixed, contact, disc)
    fixed_all = np.union1d(fixed, floating.pins)
    k = assemble_stiffness(mesh, disc, PETSc.COMM_WORLD)
    apply_dirichlet(k, fixed_all)
    return k, contact, fixed_all


def _vec(k, values):
    v = k.createVecLeft()
    v.setArray(values)
    return v


def test_schur_factor_solves_and_compliance_match_the_plain_factorization(hertz):
    k, contact, fixed = hertz
    plain = LinearSolver(k)
    plain.factor()
    one = LinearSolver(k)
    dofs = request_schur(one, contact.g, fixed)
    one.factor()
    attach_schur(one, k, dofs)
    assert one.block is not None and plain.block is None
    rng = np.random.default_rng(1)
    n = k.getSize()[0]
    full = rng.standard_normal(n)
    full[fixed] = 0.0
    contact_only = contact.g.T @ rng.standard_normal(contact.g.shape[0])
    contact_only[fixed] = 0.0
    for b in (full, contact_only):
        x1 = plain.solve(_vec(k, b)).getArray()
        x2 = one.solve(_vec(k, b)).getArray()
        assert np.abs(x1 - x2).max() <= 1e-10 * np.abs(x1).max()
    c1 = compliance_from_factor(one, contact.g, fixed)
    c2 = compliance_schur(k, contact.g, fixed)
    c3 = compliance_solve(plain, k, contact.g, fixed, to_numpy_all)
    scale = np.abs(c3).max()
    assert np.abs(c1 - c3).max() <= 1e-10 * scale
    assert np.abs(c2 - c3).max() <= 1e-10 * scale


def test_dense_factor_falls_back_to_lu_on_an_indefinite_matrix():
    s = np.array([[1.0, 2.0], [2.0, 1.0]])
    f = DenseFactor(s)
    assert f.chol is None
    b = np.array([1.0, -3.0])
    assert np.allclose(s @ f.solve(b), b)


def _p(out):
    import h5py

    with h5py.File(out / "step_0001.h5") as f:
        return f["displacement"][()], f["contact/p"][()]


@pytest.mark.mpi
def test_schur_route_on_two_ranks_matches_the_solve_route_on_one(tmp_path):
    a, b = tmp_path / "schur2", tmp_path / "solve1"
    r = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(a), "--quiet"], ranks=2)
    assert r.returncode == 0, r.stderr
    r = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(b), "--quiet",
                 "-contact_compliance", "solve"])
    assert r.returncode == 0, r.stderr
    assert read_summary(a)["compliance_route"] == "schur"
    (ua, pa), (ub, pb) = _p(a), _p(b)
    assert np.abs(ua - ub).max() <= 1e-10 * np.abs(ub).max()
    assert np.abs(pa - pb).max() <= 1e-9 * np.abs(pb).max()


@pytest.mark.parametrize("config", ["hertz.toml", "cantilever.toml"])
def test_cg_gamg_from_the_help_solves_hertz_and_the_cantilever(tmp_path, config):
    it, direct = tmp_path / "cg", tmp_path / "lu"
    r = run_cli(["run", str(CONFIGS / config), "--out", str(it), "--quiet",
                 "-ksp_type", "cg", "-pc_type", "gamg"])
    assert r.returncode == 0, r.stderr
    r = run_cli(["run", str(CONFIGS / config), "--out", str(direct), "--quiet"])
    assert r.returncode == 0, r.stderr
    e1, e2 = read_summary(it)["strain_energy"], read_summary(direct)["strain_energy"]
    assert abs(e1 - e2) <= 1e-8 * abs(e2)


@pytest.mark.parametrize("options, words", [
    (["-ksp_type", "cg", "-pc_type", "gamg", "-ksp_max_it", "3"], "did not converge"),
    (["-ksp_type", "cg", "-pc_type", "jacobi", "-ksp_rtol", "1e-5"], "inaccurate"),
])
def test_an_inaccurate_iterative_solve_is_not_called_singular(tmp_path, options, words):
    r = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(tmp_path), "--quiet",
                 *options])
    assert r.returncode == 2
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("error: ") and words in line
    assert "singular" not in line and "held by supports" not in line


@pytest.mark.parametrize("pc", ["gamg", "jacobi", "none"])
def test_preonly_with_a_preconditioner_that_does_not_factorize_says_so(tmp_path, pc):
    """-pc_type gamg without an iterative -ksp_type: before, `the stiffness is probably
    singular: check that every body is held by supports` on the (held) cantilever."""
    r = run_cli(["run", str(CONFIGS / "cantilever.toml"), "--out", str(tmp_path), "--quiet",
                 "--mesh-size", "0.5", "-pc_type", pc])
    assert r.returncode == 2
    line = r.stderr.strip().splitlines()[-1]
    assert f"-ksp_type preonly applies -pc_type {pc} once" in line
    assert "singular" not in line and "held by supports" not in line


@pytest.mark.parametrize("options", [["-ksp_type", "cg", "-pc_type", "icc"],
                                     ["-ksp_type", "bcgs", "-pc_type", "ilu"]])
def test_incomplete_factorizations_do_not_get_the_mumps_default(tmp_path, options):
    """-pc_type icc / ilu: the default -pc_factor_mat_solver_type mumps is for LU and
    Cholesky only (before: `PETSc: MatSolverType mumps does not support factorization
    type ICC ...`, exit 2, for an option the user never gave)."""
    it, direct = tmp_path / "it", tmp_path / "lu"
    r = run_cli(["run", str(CONFIGS / "cantilever.toml"), "--out", str(it), "--quiet",
                 "--mesh-size", "0.25", *options, "-ksp_max_it", "20000"])
    assert r.returncode == 0, r.stderr
    r = run_cli(["run", str(CONFIGS / "cantilever.toml"), "--out", str(direct), "--quiet",
                 "--mesh-size", "0.25"])
    assert r.returncode == 0, r.stderr
    e1, e2 = read_summary(it)["strain_energy"], read_summary(direct)["strain_energy"]
    assert abs(e1 - e2) <= 1e-8 * abs(e2)


def test_a_mumps_option_that_refuses_the_schur_set_says_to_use_the_solve_route(tmp_path):
    """-mat_mumps_icntl_28 2 (parallel analysis) is incompatible with MUMPS's Schur
    complement (INFOG(1) = -39): the error line names the way out; the solve route runs."""
    out = tmp_path / "h"
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--mesh-size", "1.0", "--out", str(out),
                   "-mat_mumps_icntl_28", "2"])
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and "INFOG(1) = -39" in lines[0]
    assert "-contact_compliance solve" in lines[0]
    assert "-contact_compliance solve" in read_summary(out)["error"]
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--mesh-size", "1.0", "--out",
                   str(tmp_path / "s"), "-mat_mumps_icntl_28", "2", "-contact_compliance",
                   "solve"])
    assert res.returncode == 0, res.stderr


def test_recovery_with_kept_columns_matches_the_solve_with_s(hertz):
    """b = G^T lambda with `forces`: u_c from the kept columns S^-1 G_c^T, the same u."""
    k, contact, fixed = hertz
    one = LinearSolver(k)
    dofs = request_schur(one, contact.g, fixed)
    one.factor()
    attach_schur(one, k, dofs)
    compliance_from_factor(one, contact.g, fixed)
    assert one.block.columns is not None
    lam = np.zeros(contact.g.shape[0])
    lam[: lam.size // 4] = np.linspace(1.0, 2.0, lam.size // 4)
    b = contact.g.T @ lam
    b[fixed] = 0.0
    x1 = one.solve(_vec(k, b)).getArray().copy()
    x2 = one.solve(_vec(k, b), forces=lam).getArray()
    cols = one.block.columns  # seeded by the compliance, or filled by this solve
    assert cols.pos[np.flatnonzero(lam)].min() >= 0 and cols.solves <= 1
    assert np.abs(x1 - x2).max() <= 1e-12 * np.abs(x1).max()
