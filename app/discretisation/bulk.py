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
from app.errors import InputError
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
# 14 s at 3000 on one core here); above, shift-invert Lanczos (about 0.3 s at 3000).
DENSE_EIG_MAX_DOFS = 500

LANCZOS_FIRST_K = 4
"""Eigenpairs Lanczos asks for first, doubled while every one found is zero-energy: each
pair asked beyond the null space is a slowly converging smallest non-zero one (a
67,813-DOF body with 3 modes: 4.8 s for 4 pairs, 8.4 s for 12)."""


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
                      factorize: Factorize = superlu_factor) -> np.ndarray:
    """Null space of one body's stiffness with its supports, (2 n_body_nodes, r).

    Rigid modes and, for CS-FEM-1SD, hourglass modes. Dense eigen-decomposition for small
    bodies, shift-invert Lanczos otherwise, its one factorization by `factorize` (the run
    passes MUMPS, `app.assembly.sequential_factor`). Rows follow the body's nodes in
    ascending order, x and y interleaved.
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
    kff = k[free][:, free]
    scale = abs(kff.diagonal()).max()
    if not (np.isfinite(kff.data).all() and np.isfinite(scale) and scale > 0):
        raise InputError(f"the stiffness of body '{mesh.body_names[body]}' is not finite or "
                         "zero (Young's modulus out of range?)")
    if free.size <= DENSE_EIG_MAX_DOFS:
        w, v = np.linalg.eigh(kff.toarray())
        keep = w < 1e-9 * w[-1]
        modes = v[:, keep]
    else:
        modes = _null_space_lanczos(kff, scale, factorize)
    out = np.zeros((n, modes.shape[1]))
    out[free] = modes
    return out


def _null_space_lanczos(kff, scale: float, factorize: Factorize) -> np.ndarray:
    """Eigenvectors of the sparse symmetric kff (n, n) with eigenvalues below 1e-9 scale,
    (n, r), by shift-invert Lanczos about -1e-8 scale: one factorization of the shifted
    (positive definite) matrix, more eigenpairs asked for while every one found is below
    the bound."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as sla_sparse

    n = kff.shape[0]
    shift = -1e-8 * scale
    factor = factorize(kff - shift * sp.identity(n, format="csr"))
    inv = sla_sparse.LinearOperator(kff.shape, matvec=factor.solve, dtype=float)
    k = min(n - 2, LANCZOS_FIRST_K)
    try:
        while True:
            w, v = sla_sparse.eigsh(kff, k=k, sigma=shift, which="LM", OPinv=inv)
            modes = v[:, w < 1e-9 * scale]
            if modes.shape[1] < k or k == n - 2:
                return modes
            k = min(n - 2, 2 * k)
    finally:
        if hasattr(factor, "destroy"):
            factor.destroy()
