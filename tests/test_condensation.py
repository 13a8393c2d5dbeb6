"""The compliance C = G K^-1 G^T (app/condensation/compliance.py) on one rank: the Schur
route and the solve route against a dense inverse of the same stiffness."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from petsc4py import PETSc

from app.assembly.solve import LinearSolver, apply_dirichlet, set_default_options
from app.assembly.stiffness import assemble_stiffness
from app.condensation.compliance import compliance_schur, compliance_solve, contact_dofs
from app.contact.pairs import constraint_matrix, contact_pairs
from app.discretisation.bulk import Discretisation
from tests.test_contact_pairs import stacked


def _to_numpy(vec: PETSc.Vec) -> np.ndarray:
    return vec.getArray().copy()  # one rank: the whole vector


@pytest.fixture(scope="module")
def problem():
    """Two stacked blocks (4 and 5 elements wide), the lower one's bottom and the upper
    one's top fixed; the pairs of the non-matching interface."""
    mesh = stacked(4, 5, ny=3)
    disc = Discretisation("cs-fem", 4, "strain", 1.0, np.array([100.0, 70.0]),
                          np.array([0.3, 0.25]))
    fixed_nodes = np.unique(np.concatenate([mesh.curves["low_bottom"].ravel(),
                                            mesh.curves["up_top"].ravel()]))
    fixed = np.sort(np.concatenate([2 * fixed_nodes, 2 * fixed_nodes + 1]))
    pairs = contact_pairs(mesh, "up_bottom", "low_top", 0.1)
    g = constraint_matrix(pairs, mesh.n_nodes)
    set_default_options()
    k = assemble_stiffness(mesh, disc, PETSc.COMM_SELF)
    indptr, indices, values = k.getValuesCSR()
    n = k.getSize()[0]
    dense = sp.csr_matrix((values, indices, indptr), shape=(n, n)).toarray()
    apply_dirichlet(k, fixed)
    solver = LinearSolver(k)
    solver.factor()
    free = np.setdiff1d(np.arange(dense.shape[0]), fixed)
    gf = g.toarray()[:, free]
    exact = gf @ np.linalg.solve(dense[np.ix_(free, free)], gf.T)
    return k, solver, g, fixed, exact


def test_schur_route_equals_dense_inverse(problem):
    k, solver, g, fixed, exact = problem
    c = compliance_schur(k, g, fixed)
    assert c is not None and c.shape == exact.shape
    np.testing.assert_allclose(c, exact, rtol=0, atol=1e-10 * np.abs(exact).max())
    assert np.allclose(c, c.T) and np.linalg.eigvalsh(c).min() > 0


def test_solve_route_equals_dense_inverse(problem):
    k, solver, g, fixed, exact = problem
    c = compliance_solve(solver, k, g, fixed, _to_numpy)
    np.testing.assert_allclose(c, exact, rtol=0, atol=1e-10 * np.abs(exact).max())


def test_contact_dofs_drop_prescribed_columns(problem):
    _, _, g, fixed, _ = problem
    dofs, gc = contact_dofs(g, fixed)
    assert not np.isin(dofs, fixed).any()
    u = np.random.default_rng(1).standard_normal(g.shape[1])
    u[fixed] = 0.0
    np.testing.assert_allclose(gc @ u[dofs], g @ u, atol=1e-14)


def test_mumps_cholesky_takes_the_solve_route(tmp_path):
    """-pc_type cholesky (MUMPS): its Schur complement is not the full S, so the run must
    take the solve route and agree with LU (before: the Schur route, a wrong compliance
    and `linear solve is inaccurate ... probably singular`, exit 2)."""
    from tests.support import read_summary, run_cli

    lu, ch = tmp_path / "lu", tmp_path / "ch"
    assert run_cli(["run", "configs/patch.toml", "--quiet", "--out", str(lu)]).returncode == 0
    r = run_cli(["run", "configs/patch.toml", "--quiet", "--out", str(ch), "-pc_type",
                 "cholesky"])
    assert r.returncode == 0, r.stderr
    a, b = read_summary(lu), read_summary(ch)
    assert (a["compliance_route"], b["compliance_route"]) == ("schur", "solve")
    assert b["strain_energy"] == pytest.approx(a["strain_energy"], rel=1e-10)
    r = run_cli(["run", "configs/patch.toml", "--quiet", "--out", str(ch), "-pc_type",
                 "cholesky", "-contact_compliance", "schur"])
    assert r.returncode == 2 and "schur compliance route needs MUMPS LU" in r.stderr
