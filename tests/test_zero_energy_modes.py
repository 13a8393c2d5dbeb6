"""The null space of a body's stiffness (rigid and 1SD hourglass modes,
`app.discretisation.bulk.zero_energy_modes`): a body of more than a few hundred free
DOFs goes to the iterative route (shift-invert Lanczos at first, now a block shift-invert
subspace iteration; the tests named `lanczos` test that route), which finds the same
modes as the dense eigen-decomposition, however many. Before, bodies up to 3000 free
DOFs were decomposed densely: the 1SD run of hertz_halfspace.toml at level 1 (`--refine
1`, a cylinder of about 2,900 free DOFs) spent 11.0 of its 12.2 s there (0.5 s with
Lanczos), and a study's 1SD times zigzagged (12.8 s at level 1, 2.8 s at level 2); and
Lanczos asked for 12 eigenpairs only, so a body with more zero-energy modes lost the rest."""

import numpy as np
from test_discretisation import distorted_grid

import app.discretisation.bulk as bulk
from app.discretisation.bulk import Discretisation, zero_energy_modes
from app.mesh.model import Mesh

ONE_SD = Discretisation("cs-fem", 1, "strain", 1.0, np.array([100.0]), np.array([0.25]))
NO_SUPPORT = np.array([], dtype=np.int64)


def projector(modes: np.ndarray) -> np.ndarray:
    q, _ = np.linalg.qr(modes)
    return q @ q.T


def both_routes(monkeypatch, mesh: Mesh) -> tuple[np.ndarray, np.ndarray]:
    monkeypatch.setattr(bulk, "DENSE_EIG_MAX_DOFS", 10_000)
    dense = zero_energy_modes(mesh, ONE_SD, 0, NO_SUPPORT)
    monkeypatch.setattr(bulk, "DENSE_EIG_MAX_DOFS", 10)
    return dense, zero_energy_modes(mesh, ONE_SD, 0, NO_SUPPORT)


def test_lanczos_finds_the_dense_null_space(monkeypatch):
    dense, lanczos = both_routes(monkeypatch, distorted_grid(14, 12))  # 390 free DOFs
    assert dense.shape == lanczos.shape == (390, 5)  # 3 rigid + 2 hourglass modes
    np.testing.assert_allclose(projector(lanczos), projector(dense), atol=1e-8)


def test_lanczos_finds_more_than_twelve_modes(monkeypatch):
    """A plate and four loose quads in one body: 5 + 4 x 5 = 25 zero-energy modes."""
    plate = distorted_grid(14, 12)
    corners = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]) * 0.1
    loose = np.vstack([corners + [2.0 + 0.2 * i, 0.0] for i in range(4)])
    n0 = plate.n_nodes
    quads = np.vstack([plate.quads, n0 + np.arange(16).reshape(4, 4)])
    mesh = Mesh(np.vstack([plate.points, loose]), quads, np.zeros(len(quads), dtype=np.int64),
                ["plate"])
    dense, lanczos = both_routes(monkeypatch, mesh)
    assert dense.shape == lanczos.shape == (2 * mesh.n_nodes, 25)
    np.testing.assert_allclose(projector(lanczos), projector(dense), atol=1e-8)


def test_a_body_of_a_thousand_dofs_is_not_decomposed_densely(monkeypatch):
    sizes = []
    eigh = np.linalg.eigh

    def spy(a, *args, **kw):
        sizes.append(len(a))
        return eigh(a, *args, **kw)

    monkeypatch.setattr(np.linalg, "eigh", spy)
    mesh = distorted_grid(36, 20)  # 777 nodes, 1,554 free DOFs
    assert zero_energy_modes(mesh, ONE_SD, 0, NO_SUPPORT).shape == (2 * mesh.n_nodes, 5)
    assert max(sizes, default=0) <= 1000, sizes


def test_mumps_factor_finds_the_same_null_space(monkeypatch):
    """The run factorizes the shifted stiffness with MUMPS on this rank
    (`SequentialCholesky`): the same modes as SciPy's SuperLU and the dense route; its
    options prefix keeps the user's stiffness options (here an iterative KSP that would
    not solve to round-off) away from it."""
    from petsc4py import PETSc

    from app.assembly.sequential_factor import SequentialCholesky

    mesh = distorted_grid(14, 12)
    dense, superlu = both_routes(monkeypatch, mesh)
    opts = PETSc.Options()
    opts.setValue("ksp_type", "richardson")
    opts.setValue("ksp_max_it", "1")
    opts.setValue("pc_type", "jacobi")
    try:
        mumps = zero_energy_modes(mesh, ONE_SD, 0, NO_SUPPORT, factorize=SequentialCholesky)
    finally:
        for name in ("ksp_type", "ksp_max_it", "pc_type"):
            opts.delValue(name)
    assert mumps.shape == dense.shape == (390, 5)
    np.testing.assert_allclose(projector(mumps), projector(dense), atol=1e-8)
    np.testing.assert_allclose(projector(mumps), projector(superlu), atol=1e-8)


def test_a_factor_with_destroy_is_destroyed(monkeypatch):
    """The factor is freed when the eigen-solve ends, not at garbage collection."""
    destroyed = []

    class Spy:
        def __init__(self, matrix):
            self.inner = bulk.superlu_factor(matrix)

        def solve(self, rhs):
            return self.inner.solve(rhs)

        def destroy(self):
            destroyed.append(True)

    monkeypatch.setattr(bulk, "DENSE_EIG_MAX_DOFS", 10)
    modes = zero_energy_modes(distorted_grid(14, 12), ONE_SD, 0, NO_SUPPORT, factorize=Spy)
    assert modes.shape[1] == 5 and destroyed == [True]


def strip(n: int, aspect: float) -> Mesh:
    """A strip one element thick: n elements of length 1 / n and height aspect / n."""
    x = np.linspace(0.0, 1.0, n + 1)
    pts = np.vstack([np.column_stack([x, np.zeros(n + 1)]),
                     np.column_stack([x, np.full(n + 1, aspect / n)])])
    i = np.arange(n)
    quads = np.column_stack([i, i + 1, n + 2 + i, n + 1 + i])
    return Mesh(pts, quads, np.zeros(n, dtype=np.int64), ["strip"])


def test_a_slender_strip_keeps_its_softest_bending_mode_out(monkeypatch):
    """A 1SD strip of n x 1 elements has n + 4 zero-energy modes (each element adds 5 and
    shares 4 DOFs, 3 strains). Its softest bending mode, 5.5e-10 of the largest
    eigenvalue here (multibody.toml's block1 at divisions [600,1]: 5.6e-10), is not one:
    the dense route took it for one (25 modes, cut at 1e-9), and shift-invert Lanczos
    about -1e-8 scale did not converge on the 600 x 1 strip (380 s, then an exception)."""
    dense, iterative = both_routes(monkeypatch, strip(20, 3000.0))
    assert dense.shape == iterative.shape == (84, 24)
    np.testing.assert_allclose(projector(iterative), projector(dense), atol=1e-8)


def test_the_basis_is_the_same_whichever_solver_found_it(monkeypatch):
    """`canonical_basis`: the columns themselves (not only their span) agree between the
    dense and iterative routes, so the amplitudes of hourglass modes in summary.json
    `rigid_modes` do not depend on the eigen-solver's arbitrary basis (1 and 2 ranks
    differed by 1.81 relative on hard/floating_gravity.toml with --sd 1)."""
    dense, iterative = both_routes(monkeypatch, distorted_grid(14, 12))
    np.testing.assert_allclose(iterative, dense, atol=1e-8)
    np.testing.assert_allclose(dense.T @ dense, np.eye(5), atol=1e-12)
    again = bulk.canonical_basis(dense @ np.linalg.qr(np.arange(25.0).reshape(5, 5) ** 2)[0])
    np.testing.assert_allclose(again, dense, atol=1e-10)


def test_the_count_stops_early_above_max_modes(monkeypatch):
    """With max_modes the block stops doubling once it holds more modes than that: a
    200 x 1 strip (204 modes) gives 64 of them, each of zero energy."""
    mesh = strip(200, 100.0)
    monkeypatch.setattr(bulk, "DENSE_EIG_MAX_DOFS", 10)
    modes = zero_energy_modes(mesh, ONE_SD, 0, NO_SUPPORT, max_modes=32)
    assert modes.shape == (804, 64)
    k = bulk.element_matrices(mesh, ONE_SD, np.arange(200))
    dofs = np.stack([2 * mesh.quads, 2 * mesh.quads + 1], axis=-1).reshape(200, 8)
    energy = np.einsum("eim,eij,ejm->m", modes[dofs], k, modes[dofs])
    assert energy.max() <= 1e-12 * np.abs(k).max()
    assert zero_energy_modes(mesh, ONE_SD, 0, NO_SUPPORT).shape == (804, 204)


def test_a_body_with_every_dof_supported_has_no_modes():
    """hard/tangential_contrast.toml --sd 1 --mesh-size 4: a body whose every DOF is
    supported ended in a traceback (the largest entry of an empty diagonal)."""
    mesh = distorted_grid(2, 2)
    every = np.arange(2 * mesh.n_nodes)
    assert zero_energy_modes(mesh, ONE_SD, 0, every).shape == (2 * mesh.n_nodes, 0)


def graded(g: float) -> Mesh:
    """distorted_grid(14, 12) with x mapped to exp(g x / max x): element widths growing
    geometrically by e^g across the body (aspect ratios up to ~1e3-1e4), so that its
    softest non-zero eigenvalues come down to 1e-12 of its stiffness's scale."""
    base = distorted_grid(14, 12)
    p = base.points.copy()
    p[:, 0] = np.exp(g * p[:, 0] / p[:, 0].max())
    return Mesh(p, base.quads, np.zeros(len(base.quads), dtype=np.int64), ["graded"])


def test_both_routes_count_the_same_modes_near_the_cut(monkeypatch):
    """Graded by e^6, the body's sixth eigenvalue is 2.0e-12 of its largest diagonal entry
    and below 1e-12 of its largest eigenvalue: the dense route cut at NULL_REL x the
    largest eigenvalue (6 modes), the iterative one at NULL_REL x the diagonal (5), so
    the count depended on the body's size (DENSE_EIG_MAX_DOFS). Both cut at the latter."""
    dense, iterative = both_routes(monkeypatch, graded(6.0))
    assert dense.shape[1] == iterative.shape[1] == 5


def test_a_mode_just_under_the_cut_settles(monkeypatch):
    """Graded by e^6.5 and e^7, a mode lies between NULL_RESIDUAL and NULL_REL x scale:
    counted as zero energy, its |K v| (= its eigenvalue) never fell below NULL_RESIDUAL,
    and the iteration stopped with `did not converge`; the eigen-residual |K v - w v|
    settles, with the dense route's count."""
    for g, count in ((6.5, 6), (7.0, 7)):
        dense, iterative = both_routes(monkeypatch, graded(g))
        assert dense.shape[1] == iterative.shape[1] == count
        np.testing.assert_allclose(projector(iterative), projector(dense), atol=2e-2)
