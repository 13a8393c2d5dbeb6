"""The bulk discretisation of a scene: materials, method, element matrices and fields.

Plain numpy on top of the element kernels; no MPI and no files.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from app.discretisation.elements import (
    cell_strains,
    elasticity_matrix,
    element_areas,
    stiffness_blocks,
)
from app.discretisation.methods import BulkMethod, bulk_method, cell_gradients, strain_matrices
from app.errors import InputError, SolveError
from app.mesh.model import Mesh


@dataclass
class Discretisation:
    """Method and materials: E, nu per body; plane 'strain' or 'stress'."""

    method: str  # a name in app.discretisation.methods.BULK_METHODS
    sd: int  # smoothing cells per element (methods that take one)
    plane: str  # "strain" | "stress"
    thickness: float
    E: np.ndarray  # (n_bodies,)
    nu: np.ndarray  # (n_bodies,)

    @property
    def bulk(self) -> BulkMethod:
        """The registered method."""
        return bulk_method(self.method)

    @property
    def label(self) -> str:
        """e.g. "CS-FEM-4SD" or "FEM-Q4"."""
        return self.bulk.label(self.sd)

    @property
    def hourglass(self) -> bool:
        """True when the element stiffness has zero-energy (hourglass) modes."""
        return self.bulk.hourglass(self.sd)

    def d_matrices(self, body: np.ndarray) -> np.ndarray:
        """Elasticity matrix per element, (n, 3, 3)."""
        return elasticity_matrix(self.E, self.nu, self.plane)[body]


# Volumetric locking in plane strain: above this nu every method without hourglass modes
# (CS-FEM with sd >= 2, FEM-Q4) is too stiff on bilinear quads. Measured on
# cantilever.toml at h = 0.125 (README "Bulk"): tip deflection errors at nu = 0.45 / 0.49.
NU_LOCKING = 0.45
_LOCKING_FIGURES = ("measured on configs/cantilever.toml at --mesh-size 0.125, tip deflection "
                    "off by 2.2% / 11.8% with CS-FEM-4SD, 3.4% / 15.4% with FEM-Q4 and "
                    "1.6% / 1.5% with CS-FEM-1SD at nu = 0.45 / 0.49")


def locking_warnings(disc: Discretisation, body_names: list[str]) -> list[str]:
    """One warning per body whose nu > NU_LOCKING in plane strain with a method that locks
    (one without hourglass modes); none in plane stress, where lambda stays bounded."""
    if disc.plane != "strain" or disc.hourglass:
        return []
    return [
        f"body '{name}': nu = {nu:g} in plane strain: {disc.label} locks (volumetric "
        f"locking: too stiff, displacements and energy too small) above nu = {NU_LOCKING:g}; "
        f"{_LOCKING_FIGURES}: use --sd 1 (no locking; supports or contact must hold its "
        "hourglass modes) or check the answer on a finer mesh"
        for name, nu in zip(body_names, np.asarray(disc.nu, float), strict=True)
        if nu > NU_LOCKING
    ]


def check_elements(mesh: Mesh) -> None:
    """Reject inverted or degenerate elements with a message naming the body."""
    area = element_areas(mesh.points[mesh.quads])
    bad = np.flatnonzero(area <= 1e-14 * np.max(np.abs(area)))
    if bad.size:
        e = int(bad[0])
        c = mesh.points[mesh.quads[e]].mean(axis=0)
        raise InputError(
            f"body '{mesh.body_names[mesh.body[e]]}': {bad.size} element(s) are inverted or "
            f"degenerate (first near x={c[0]:.4g}, y={c[1]:.4g}): fix the mesh"
        )


def element_blocks(mesh: Mesh, disc: Discretisation, elements: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Element stiffness of the given elements as (K_uu, K_uv, K_vu, K_vv), each (n, 4, 4)."""
    xe = mesh.points[mesh.quads[elements]]
    bx, by, w = cell_gradients(xe, disc.method, disc.sd)
    return stiffness_blocks(bx, by, w, disc.d_matrices(mesh.body[elements]), disc.thickness)


def element_matrices(mesh: Mesh, disc: Discretisation, elements: np.ndarray) -> np.ndarray:
    """Element stiffness matrices (n, 8, 8) of the given elements (thickness included)."""
    kuu, kuv, kvu, kvv = element_blocks(mesh, disc, elements)
    k = np.empty((len(elements), 8, 8))
    k[:, 0::2, 0::2], k[:, 0::2, 1::2] = kuu, kuv
    k[:, 1::2, 0::2], k[:, 1::2, 1::2] = kvu, kvv
    return k


def element_operators(mesh: Mesh, disc: Discretisation, elements: np.ndarray,
                      chunk: int = 200_000) -> list[tuple[np.ndarray, np.ndarray]]:
    """(B (n, n_cells, 3, 8), weights (n, n_cells)) per chunk of `element_fields`: they
    depend on the mesh only, so a run of many steps forms them once (memory: 8 x 24
    n_cells bytes per element, 768 for 4SD)."""
    return [strain_matrices(mesh.points[mesh.quads[elements[s : s + chunk]]], disc.method,
                            disc.sd) for s in range(0, elements.size, chunk)]


def element_fields(mesh: Mesh, disc: Discretisation, u: np.ndarray, elements: np.ndarray,
                   chunk: int = 200_000,
                   operators: list[tuple[np.ndarray, np.ndarray]] | None = None
                   ) -> dict[str, np.ndarray]:
    """Cell-averaged fields of the given elements from the global displacement u (2n,).

    Returns stress (n, 4) = (s_xx, s_yy, s_xy, s_zz) (area-weighted over the element's
    cells; s_zz = nu (s_xx + s_yy) in plane strain, 0 in plane stress), von_mises (n,),
    energy (n,) strain energy of the element (thickness included) and
    energy_density (n,) = energy / (area * thickness). operators: `element_operators` of
    the same elements and chunk, else formed here.
    """
    out = {k: [] for k in ("stress", "von_mises", "energy", "energy_density")}
    for k, s in enumerate(range(0, elements.size, chunk)):
        el = elements[s : s + chunk]
        if operators is None:
            b, w = strain_matrices(mesh.points[mesh.quads[el]], disc.method, disc.sd)
        else:
            b, w = operators[k]
        d = disc.d_matrices(mesh.body[el])
        ue = u.reshape(-1, 2)[mesh.quads[el]].reshape(-1, 8)
        eps = cell_strains(b, ue)  # (n, nc, 3)
        sig = np.einsum("nij,ncj->nci", d, eps)
        area = w.sum(axis=1)
        energy = 0.5 * disc.thickness * np.einsum("nci,nci,nc->n", eps, sig, w)
        s_avg = np.einsum("nci,nc->ni", sig, w) / area[:, None]
        nu = disc.nu[mesh.body[el]]
        szz = nu * (s_avg[:, 0] + s_avg[:, 1]) if disc.plane == "strain" else 0.0 * nu
        sxx, syy, sxy = s_avg[:, 0], s_avg[:, 1], s_avg[:, 2]
        vm = np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2)
                     + 3.0 * sxy**2)
        out["stress"].append(np.column_stack([sxx, syy, sxy, szz]))
        out["von_mises"].append(vm)
        out["energy"].append(energy)
        out["energy_density"].append(energy / (area * disc.thickness))
    return {k: np.concatenate(v) if v else np.zeros((0, 4) if k == "stress" else 0)
            for k, v in out.items()}


# Free DOFs up to which a body's null space comes from a dense eigh (n^3: 0.1 s at 500,
# 14 s at 3000 on one core here); above, shift-invert block subspace iteration.
DENSE_EIG_MAX_DOFS = 500

NULL_BLOCK_FIRST = 8
"""Block size the subspace iteration starts with, doubled while every Ritz pair of the
block is zero-energy (a CS-FEM-1SD strip one element thick has n_elements + 4 modes)."""

NULL_REL = 1e-12
"""An eigenvalue (Ritz value) below this x the stiffness's scale is zero energy. Exact
null vectors reach 1e-16 to 1e-15; a slender body's softest bending mode falls as
(length / thickness)^4 per element: a CS-FEM-1SD strip of n x 1 elements of
multibody.toml's block1 has lambda_1 = 1.1e-5, 1.4e-7, 8.9e-9 of the largest eigenvalue
at n = 50, 150, 300 (5.6e-10 at 600: below the 1e-9 used before, which took it for a
zero-energy mode)."""

NULL_SHIFT = 1e-11
"""The shift-invert factorizes K + NULL_SHIFT scale I: each application divides a mode's
non-null part by lambda / (NULL_SHIFT scale), at least 50 for lambda_1 above 5e-10 scale
(with 1e-8 before, 0.95 at the 600 x 1 strip: the eigen-solve did not converge)."""

NULL_RESIDUAL = 1e-13
"""The iteration stops when every zero-energy Ritz pair (w, v) has |K v - w v| below this x
the scale and their count is stable (exact null vectors reach about 1e-15). With |K v|
instead, a mode counted as zero energy (w below NULL_REL scale) but above this never
settled: a body graded to element aspect ratios of 1e4 stopped with `did not converge`."""

NULL_MAX_ITERATIONS = 12
"""Shift-inverted applications per block before the iteration is given up as unsettled."""

MODE_SEED = 20240917
"""Seed of the fixed vectors that start the iteration and fix the basis (`canonical_basis`)."""


class Factor(Protocol):
    """A factorized sparse matrix A (n, n): solve(rhs) is A^-1 rhs, (n,)."""

    def solve(self, rhs: np.ndarray) -> np.ndarray: ...


Factorize = Callable[..., Factor]
"""Factorizes a sparse SPD matrix (scipy.sparse, (n, n)); a factor with a `destroy()`
method is destroyed when the eigen-solve ends."""


def superlu_factor(matrix) -> Factor:
    """SciPy's SuperLU with a symmetric ordering (numpy-only default of `factorize`)."""
    import scipy.sparse.linalg as sla_sparse

    return sla_sparse.splu(matrix.tocsc(), permc_spec="MMD_AT_PLUS_A")


def zero_energy_modes(mesh: Mesh, disc, body: int, fixed: np.ndarray,
                      factorize: Factorize = superlu_factor,
                      max_modes: int | None = None) -> np.ndarray:
    """Null space of one body's stiffness with its supports, (2 n_body_nodes, r).

    Rigid modes and, for CS-FEM-1SD, hourglass modes. Dense eigen-decomposition for small
    bodies, shift-invert block subspace iteration otherwise, its one factorization by
    `factorize` (the run passes MUMPS, `app.assembly.sequential_factor`). The columns are
    `canonical_basis` of the null space (the same whichever solver found it). Rows follow
    the body's nodes in ascending order, x and y interleaved. With `max_modes`, the
    iterative route stops once it has found more than that many (then the columns are
    some of the modes, more than max_modes).
    """
    import scipy.sparse as sp

    el = np.flatnonzero(mesh.body == body)
    nodes = np.unique(mesh.quads[el])
    local = np.full(mesh.n_nodes, -1)
    local[nodes] = np.arange(nodes.size)
    ke = element_matrices(mesh, disc, el)
    ld = np.stack([2 * local[mesh.quads[el]], 2 * local[mesh.quads[el]] + 1],
                  axis=-1).reshape(el.size, 8)
    n = 2 * nodes.size
    k = sp.coo_matrix((ke.ravel(), (np.repeat(ld, 8, axis=1).ravel(),
                                    np.tile(ld, (1, 8)).ravel())), shape=(n, n)).tocsr()
    gdofs = np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()
    free = np.flatnonzero(~np.isin(gdofs, fixed))
    if free.size == 0:  # every DOF supported (a one-element body at a coarse mesh size)
        return np.zeros((n, 0))
    kff = k[free][:, free]
    scale = abs(kff.diagonal()).max()
    if not (np.isfinite(kff.data).all() and np.isfinite(scale) and scale > 0):
        raise InputError(f"the stiffness of body '{mesh.body_names[body]}' is not finite or "
                         "zero (Young's modulus out of range?)")
    if free.size <= DENSE_EIG_MAX_DOFS:
        w, v = np.linalg.eigh(kff.toarray())
        modes = v[:, w < NULL_REL * scale]  # the iterative route's cut, so both agree
    else:
        modes = _null_space_iterative(kff, scale, factorize, mesh.body_names[body],
                                      max_modes)
    out = np.zeros((n, modes.shape[1]))
    out[free] = canonical_basis(modes)
    return out


def _null_space_iterative(kff, scale: float, factorize: Factorize, name: str,
                          max_modes: int | None = None) -> np.ndarray:
    """Orthonormal eigenvectors of the sparse symmetric PSD kff (n, n) with eigenvalues
    below NULL_REL scale, (n, r), by block shift-invert subspace iteration about
    -NULL_SHIFT scale: one factorization of the shifted (positive definite) matrix; the block
    starts at NULL_BLOCK_FIRST columns and doubles while every Ritz pair is zero-energy
    (and, with max_modes, while it holds at most that many). Raises SolveError naming the
    body `name` when the iteration does not settle."""
    import scipy.sparse as sp

    n = kff.shape[0]
    factor = factorize(kff + NULL_SHIFT * scale * sp.identity(n, format="csr"))
    rng = np.random.default_rng(MODE_SEED)
    found = np.zeros((n, 0))
    p = min(n, NULL_BLOCK_FIRST)
    try:
        while True:
            x = np.hstack([found, rng.standard_normal((n, p - found.shape[1]))])
            found = _subspace_iteration(kff, scale, factor, x, name)
            if found.shape[1] < p or p == n or (max_modes is not None and p > max_modes):
                return found
            p = min(n, 2 * p)
    finally:
        if hasattr(factor, "destroy"):
            factor.destroy()


def _subspace_iteration(kff, scale: float, factor: Factor, x: np.ndarray,
                        name: str) -> np.ndarray:
    """Zero-energy Ritz vectors (n, r) of kff from the start block x (n, p), iterated with
    the shifted inverse `factor` until their residuals |kff v| are below NULL_RESIDUAL
    scale and their count is stable."""
    count = -1
    for _ in range(NULL_MAX_ITERATIONS):
        q, _ = np.linalg.qr(_solve_block(factor, x))
        kq = kff @ q
        w, s = np.linalg.eigh(q.T @ kq)
        null = w < NULL_REL * scale
        v, kv = q @ s[:, null], kq @ s[:, null]
        # the eigen-residual |kff v - w v|: |kff v| is w itself for an exact eigenvector,
        # so one between NULL_RESIDUAL and NULL_REL x scale never converged
        res = np.linalg.norm(kv - v * w[null], axis=0).max(initial=0.0)
        if res <= NULL_RESIDUAL * scale and null.sum() == count:
            return v
        count, x = int(null.sum()), q @ s
    raise SolveError(f"the zero-energy modes of body '{name}' did not converge ({count} "
                     f"found, residual {res / scale:.1e} of its stiffness after "
                     f"{NULL_MAX_ITERATIONS} iterations): use --sd 2 or more "
                     "(hourglass-free smoothing) or --method fem-q4")


def _solve_block(factor: Factor, x: np.ndarray) -> np.ndarray:
    """factor^-1 x for a block x (n, p): `solve_block` when the factor has one."""
    if hasattr(factor, "solve_block"):
        return factor.solve_block(x)
    return np.column_stack([factor.solve(c) for c in x.T])


def canonical_basis(modes: np.ndarray) -> np.ndarray:
    """An orthonormal basis (n, r) of the span of `modes` (n, r) that depends on the span
    only: the projections of fixed seeded vectors (MODE_SEED), orthonormalised in order
    (QR, positive diagonal). An eigen-solver returns some basis of a repeated (zero)
    eigenvalue; this one is the same whichever it was, so the amplitudes of the modes are
    too."""
    n, r = modes.shape
    if r == 0:
        return modes
    q0, _ = np.linalg.qr(modes)
    x = np.random.default_rng(MODE_SEED).standard_normal((n, r))
    q, rr = np.linalg.qr(q0 @ (q0.T @ x))
    return q * np.where(np.diag(rr) < 0, -1.0, 1.0)
