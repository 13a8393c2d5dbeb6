"""Bulk discretisation: patch test of every variant, energy ordering, convergence."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from support import CONFIGS

from app.assembly.stiffness import assemble_stiffness
from app.closed_form import timoshenko_cantilever
from app.config import load_config
from app.discretisation.bulk import Discretisation
from app.discretisation.elements import smoothing_cells
from app.discretisation.methods import strain_matrices
from app.errors import InputError
from app.mesh.model import Mesh
from app.run import RunOptions, run

VARIANTS = [("cs-fem", 1), ("cs-fem", 2), ("cs-fem", 3), ("cs-fem", 4), ("cs-fem", 8),
            ("cs-fem", 16), ("fem-q4", 4)]


def distorted_grid(nx: int, ny: int, distort: float = 0.6, seed: int = 1) -> Mesh:
    """Unit square of nx x ny quads with interior nodes moved randomly."""
    x, y = np.meshgrid(np.linspace(0, 1, nx + 1), np.linspace(0, 1, ny + 1))
    pts = np.c_[x.ravel(), y.ravel()]
    inner = (pts[:, 0] > 0) & (pts[:, 0] < 1) & (pts[:, 1] > 0) & (pts[:, 1] < 1)
    rng = np.random.default_rng(seed)
    pts[inner] += distort * (rng.random((inner.sum(), 2)) - 0.5) / max(nx, ny)
    i, j = np.meshgrid(np.arange(nx), np.arange(ny))
    n0 = (j * (nx + 1) + i).ravel()
    quads = np.c_[n0, n0 + 1, n0 + nx + 2, n0 + nx + 1]
    return Mesh(pts, quads, np.zeros(len(quads), dtype=np.int64), ["plate"])


def dense(mat) -> np.ndarray:
    ai, aj, av = mat.getValuesCSR()
    return sp.csr_matrix((av, aj, ai), shape=mat.getSize()).toarray()


@pytest.mark.parametrize("method,sd", VARIANTS)
@pytest.mark.parametrize("plane", ["strain", "stress"])
def test_patch_test_reproduces_linear_field(method, sd, plane):
    mesh = distorted_grid(7, 6)
    disc = Discretisation(method, sd, plane, 0.7, np.array([210.0]), np.array([0.3]))
    k = dense(assemble_stiffness(mesh, disc))
    x = mesh.points
    u = np.zeros(2 * mesh.n_nodes)
    u[0::2] = 1e-3 * (1.0 + 2.0 * x[:, 0] + 3.0 * x[:, 1])
    u[1::2] = 1e-3 * (-1.0 + 0.5 * x[:, 0] - 1.5 * x[:, 1])
    boundary = np.any((x < 1e-12) | (x > 1 - 1e-12), axis=1)
    d = np.flatnonzero(np.repeat(boundary, 2))
    f = np.setdiff1d(np.arange(2 * mesh.n_nodes), d)
    uf = np.linalg.solve(k[np.ix_(f, f)], -k[np.ix_(f, d)] @ u[d])
    err = np.abs(uf - u[f]).max() / np.abs(u).max()
    assert err < 1e-10, f"{method} {sd}SD patch test error {err:.2e}"


@pytest.mark.parametrize("method,sd", VARIANTS)
def test_rigid_modes_have_zero_energy_and_hourglass_only_for_1sd(method, sd):
    mesh = distorted_grid(5, 4)
    disc = Discretisation(method, sd, "strain", 1.0, np.array([100.0]), np.array([0.25]))
    k = dense(assemble_stiffness(mesh, disc))
    assert np.allclose(k, k.T, atol=1e-10 * np.abs(k).max())
    eig = np.linalg.eigvalsh(k)
    zero = np.sum(eig < 1e-9 * eig[-1])
    assert zero == (5 if sd == 1 and method == "cs-fem" else 3)


def test_smoothing_cells_tile_the_parent_square():
    for sd in (1, 2, 3, 4, 8, 16):
        cells = smoothing_cells(sd)
        assert len(cells) == sd
        assert sum((c[1] - c[0]) * (c[3] - c[2]) for c in cells) == pytest.approx(4.0)
    with pytest.raises(InputError, match="sd = 5"):
        smoothing_cells(5)


def test_cell_weights_sum_to_element_area():
    mesh = distorted_grid(3, 3)
    xe = mesh.points[mesh.quads]
    for method, sd in VARIANTS:
        _, w = strain_matrices(xe, method, sd)
        assert w.sum() == pytest.approx(1.0, rel=1e-12)


def _cantilever(tmp_path, method, sd, h):
    cfg = load_config(CONFIGS / "cantilever.toml")
    opts = RunOptions(out=tmp_path / f"{method}{sd}_{h}", method=method, sd=sd,
                      mesh_scale=h / cfg.mesh_size, quiet=True)
    return run(cfg, opts)


def test_energy_ordering_and_convergence_to_timoshenko(tmp_path):
    exact = timoshenko_cantilever(10.0, 0.0, P=1.0, L=10.0, D=1.0, E=1000.0, nu=0.3)
    sizes = [0.25, 0.125, 0.0625]
    table = {}
    for method, sd in VARIANTS:
        for h in sizes:
            s = _cantilever(tmp_path, method, sd, h)
            table[(method, sd, h)] = (s["point_values"]["tip"]["uy"], s["strain_energy"])
    print("\nmethod      h        tip err     energy err   (rates)")
    for h in sizes:
        energies = [table[(m, sd, h)][1] for m, sd in VARIANTS]
        # the seed paper's ordering: U(1SD) >= U(2SD) >= ... >= U(16SD) >= U(FEM-Q4)
        assert all(a >= b for a, b in zip(energies, energies[1:], strict=False)), energies
    for method, sd in VARIANTS:
        tip_err = [abs(table[(method, sd, h)][0] - exact["tip_deflection"]) for h in sizes]
        en_err = [abs(table[(method, sd, h)][1] - exact["strain_energy"]) for h in sizes]
        rate_tip = np.log2(tip_err[-2] / tip_err[-1])
        rate_en = np.log2(en_err[-2] / en_err[-1])
        label = "FEM-Q4" if method == "fem-q4" else f"{sd}SD"
        for h, et, ee in zip(sizes, tip_err, en_err, strict=True):
            print(f"{label:8s} {h:8.4f}  {et:10.3e}  {ee:10.3e}")
        print(f"{label:8s} observed rates: tip {rate_tip:.2f}, energy {rate_en:.2f}")
        assert tip_err[-1] < tip_err[0] / 8
        assert rate_tip > 1.7 and rate_en > 1.7
        assert tip_err[-1] / abs(exact["tip_deflection"]) < 5e-3


def test_body_force_and_traction_vectors_sum_to_resultants():
    from app.assembly.loads import body_force_vector, traction_vector
    from app.config import parse_config

    mesh = distorted_grid(4, 3)
    raw = {"mesh": {"size": 0.25}, "analysis": {"thickness": 0.5},
           "body": [{"name": "plate", "E": 1.0, "nu": 0.3, "body_force": [2.0, -9.81],
                     "shape": {"type": "rectangle", "origin": [0.0, 0.0], "width": 1.0,
                               "height": 1.0}}]}
    cfg = parse_config(raw)
    f = body_force_vector(mesh, cfg)
    assert f[0::2].sum() == pytest.approx(2.0 * 1.0 * 0.5)
    assert f[1::2].sum() == pytest.approx(-9.81 * 1.0 * 0.5)
    # a linear traction on the bottom edge y = 0: consistent forces reproduce its moment
    bottom = np.flatnonzero(mesh.points[:, 1] < 1e-12)
    bottom = bottom[np.argsort(mesh.points[bottom, 0])]
    edges = np.c_[bottom[:-1], bottom[1:]]
    fv = traction_vector(mesh, edges, lambda x, y: np.c_[0 * x, 3.0 * x])
    assert fv[1::2].sum() == pytest.approx(1.5)  # integral of 3x over [0, 1]
    assert (fv[1::2] * mesh.points[:, 0]).sum() == pytest.approx(1.0)  # integral of 3x^2


@pytest.mark.parametrize("method,sd", VARIANTS)
def test_stiffness_blocks_equal_the_b_transpose_d_b_sum(method, sd):
    from app.discretisation.elements import elasticity_matrix, stiffness_blocks
    from app.discretisation.methods import cell_gradients

    xe = distorted_grid(3, 2).points[distorted_grid(3, 2).quads]
    b, w = strain_matrices(xe, method, sd)
    d = np.broadcast_to(elasticity_matrix(210.0, 0.3, "stress"), (len(xe), 3, 3))
    ref = np.einsum("ncia,nij,ncjb,nc->nab", b, d, b, 0.7 * w)
    kuu, kuv, kvu, kvv = stiffness_blocks(*cell_gradients(xe, method, sd), d, 0.7)
    for blk, (i, j) in ((kuu, (0, 0)), (kuv, (0, 1)), (kvu, (1, 0)), (kvv, (1, 1))):
        assert np.allclose(blk, ref[:, i::2, j::2], rtol=1e-12, atol=1e-12 * np.abs(ref).max())
