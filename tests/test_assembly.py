"""Stiffness assembly: the compiled kernel against the numpy reference, on 1 and 2 ranks."""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest
import scipy.sparse as sp
from support import ROOT, mpi_env
from test_discretisation import VARIANTS, dense, distorted_grid

from app.assembly import compiled
from app.assembly.stiffness import assemble_stiffness
from app.discretisation.bulk import Discretisation
from app.discretisation.methods import cell_gradients
from app.mesh.model import Mesh

needs_kernel = pytest.mark.skipif(compiled.kernel() is None,
                                  reason="compiled kernel not built")


def two_body_mesh(nx: int = 7, ny: int = 6, seed: int = 3) -> Mesh:
    """A distorted grid with two materials and randomly numbered nodes, so that a range of
    node numbers (a rank's rows) cuts elements everywhere."""
    m = distorted_grid(nx, ny)
    perm = np.random.default_rng(seed).permutation(m.n_nodes)  # old -> new number
    points = np.empty_like(m.points)
    points[perm] = m.points
    body = (np.arange(m.n_elements) % 3 == 0).astype(np.int64)
    return Mesh(points, perm[m.quads], body, ["soft", "hard"])


def discretisation(method: str, sd: int, plane: str = "strain") -> Discretisation:
    return Discretisation(method, sd, plane, 0.7, np.array([70.0, 210.0]),
                          np.array([0.2, 0.3]))


def split_rows(g: compiled.SplitCSR, n_nodes: int) -> sp.csr_matrix:
    """The rows of a SplitCSR as a (2 (n1 - n0), 2 n_nodes) matrix with global columns."""
    rows = 2 * (g.n1 - g.n0)
    diag = sp.csr_matrix((g.dval, g.dind + 2 * g.n0, g.dptr), shape=(rows, 2 * n_nodes))
    off = sp.csr_matrix((g.oval, g.oind, g.optr), shape=(rows, 2 * n_nodes))
    return (diag + off).tocsr()


def test_compiled_kernel_is_built():
    assert compiled.kernel() is not None, (
        "app/assembly/_kernel.c was not compiled: `bash scripts/setup.sh` builds it "
        "(needs gcc and python3-dev)")


@pytest.mark.parametrize("method,sd", VARIANTS)
def test_cell_operators_reproduce_cell_gradients(method, sd):
    """The kernel's constant operators give the numpy kernels' gradients and weights."""
    mesh = distorted_grid(4, 3)
    xe = mesh.points[mesh.quads] + np.array([3.0, -2.0])  # away from the origin
    bx, by, w = cell_gradients(xe, method, sd)
    tops, sops, gw = compiled.cell_operators(method, sd)
    x = xe[..., 0] - xe[:, :1, 0]  # relative to the first node, as the kernel does
    y = xe[..., 1] - xe[:, :1, 1]
    s = np.zeros((len(gw), 4, 4))
    upper = np.triu_indices(4, 1)
    s[:, upper[0], upper[1]] = sops
    s -= s.transpose(0, 2, 1)
    m = np.einsum("na,cab,nb->nc", x, s, y)
    scale = np.abs(bx).max()
    assert np.allclose(np.einsum("cab,nb->nca", tops, y) / m[..., None], bx,
                       rtol=0, atol=1e-13 * scale)
    assert np.allclose(-np.einsum("cab,nb->nca", tops, x) / m[..., None], by,
                       rtol=0, atol=1e-13 * scale)
    assert np.allclose(gw * m, w, rtol=1e-13)


@needs_kernel
@pytest.mark.parametrize("method,sd", VARIANTS)
@pytest.mark.parametrize("plane", ["strain", "stress"])
def test_compiled_rows_match_numpy_on_any_node_range(method, sd, plane):
    """Without MPI: the rows of every node range, stacked, are the reference matrix; the
    ranges include an empty one and ones that cut elements."""
    mesh, disc = two_body_mesh(), discretisation(method, sd, plane)
    ref = sp.csr_matrix(dense(assemble_stiffness(mesh, disc, route="numpy")))
    for bounds in ([0, mesh.n_nodes], [0, 17, 17, 40, mesh.n_nodes]):
        parts = [compiled.local_stiffness(mesh, disc, n0, n1)
                 for n0, n1 in zip(bounds[:-1], bounds[1:], strict=True)]
        k = sp.vstack([split_rows(g, mesh.n_nodes) for g in parts]).tocsr()
        assert abs(k - ref).max() <= 1e-12 * abs(ref).max()
        for g in parts:  # columns sorted and in the right part
            n_rows = 2 * (g.n1 - g.n0)
            for ptr, ind in ((g.dptr, g.dind), (g.optr, g.oind)):
                for r in range(n_rows):
                    assert np.all(np.diff(ind[ptr[r]:ptr[r + 1]]) > 0)
            assert np.all(g.dind < n_rows)
            assert not np.any((g.oind >= 2 * g.n0) & (g.oind < 2 * g.n1))


@needs_kernel
def test_sparsity_is_the_node_graph():
    """Entries are exactly the node pairs that share an element (pattern as the numpy
    route, zeros of a 1-element mesh included), for 32- and 64-bit indices."""
    mesh, disc = two_body_mesh(5, 4), discretisation("cs-fem", 4)
    ai, aj, _ = assemble_stiffness(mesh, disc, route="compiled").getValuesCSR()
    bi, bj, _ = assemble_stiffness(mesh, disc, route="numpy").getValuesCSR()
    assert np.array_equal(ai, bi) and np.array_equal(aj, bj)
    g32 = compiled.local_stiffness(mesh, disc, 10, 25, np.int32)
    g64 = compiled.local_stiffness(mesh, disc, 10, 25, np.int64)
    for name in ("dptr", "dind", "dval", "optr", "oind", "oval"):
        assert np.array_equal(getattr(g32, name), getattr(g64, name))
    assert g64.dind.dtype == np.int64


@needs_kernel
@pytest.mark.parametrize("method,sd", VARIANTS)
def test_compiled_matrix_equals_numpy_matrix_on_one_rank(method, sd):
    mesh, disc = two_body_mesh(), discretisation(method, sd)
    a = assemble_stiffness(mesh, disc, route="compiled")
    b = assemble_stiffness(mesh, disc, route="numpy")
    assert a.getType() == b.getType()
    ai, aj, av = a.getValuesCSR()
    bi, bj, bv = b.getValuesCSR()
    assert np.array_equal(ai, bi) and np.array_equal(aj, bj)
    assert np.abs(av - bv).max() <= 1e-12 * np.abs(bv).max()


def test_auto_falls_back_to_numpy_without_the_kernel(monkeypatch):
    mesh, disc = two_body_mesh(4, 3), discretisation("cs-fem", 4)
    ref = dense(assemble_stiffness(mesh, disc, route="numpy"))
    monkeypatch.setattr(compiled, "_LIB", None)
    monkeypatch.setattr(compiled, "_TRIED", True)
    assert compiled.kernel() is None
    assert np.array_equal(dense(assemble_stiffness(mesh, disc)), ref)
    with pytest.raises(RuntimeError, match="not built"):
        assemble_stiffness(mesh, disc, route="compiled")
    with pytest.raises(ValueError, match="route"):
        assemble_stiffness(mesh, disc, route="fast")


@needs_kernel
@pytest.mark.mpi
def test_compiled_matrix_equals_numpy_matrix_on_two_ranks():
    import shutil
    import subprocess

    mpiexec = shutil.which("mpiexec")
    if mpiexec is None:
        pytest.fail("mpiexec not found: install openmpi-bin (scripts/setup.sh does)")
    res = subprocess.run([mpiexec, "-n", "2", sys.executable, "tests/mpi_assembly.py"],
                         cwd=ROOT, env=mpi_env(), capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    rows = [json.loads(line) for line in res.stdout.splitlines() if line.startswith("{")]
    assert len(rows) == 2 * len(VARIANTS)
    for r in rows:
        assert r["type"] == "mpiaij" and r["same_pattern"], r
        assert r["value_error"] <= 1e-12 and r["product_error"] <= 1e-12, r
