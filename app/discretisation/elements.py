"""Element kernels for Q4 meshes: CS-FEM smoothed strain matrices and FEM-Q4 (2x2 Gauss).

Everything is vectorised over elements; the only Python loops run over the (at most 16)
smoothing cells or Gauss points of the reference element.

Conventions
- Element node order is counter-clockwise; element DOFs are (u1, v1, u2, v2, u3, v3, u4, v4).
- Strain vector is (eps_xx, eps_yy, gamma_xy) (engineering shear), stress (s_xx, s_yy, s_xy).
- A "cell" is a smoothing cell (CS-FEM) or a Gauss point (FEM-Q4); `weights` are the cell
  areas (CS-FEM) or det(J) * w_gauss (FEM-Q4), so that  K_e = t * sum_c w_c B_c^T D B_c.

Smoothing-cell layouts in the parent square [-1, 1]^2 (xi along edge 1->2, eta along 1->4):
  1SD: the element;            2SD: 2 x 1 (split at xi = 0);
  3SD: the half xi < 0, plus the half xi > 0 split at eta = 0;
  4SD: 2 x 2;                  8SD: 4 x 2 (4 along xi);      16SD: 4 x 4.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from app.errors import InputError
from app.mesh.model import polygon_areas

# Parent coordinates of the Q4 corners, counter-clockwise.
_CORNERS = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


def shape_functions(xi: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """Bilinear Q4 shape functions at parent points; shape (..., 4)."""
    xi = np.asarray(xi, dtype=float)[..., None]
    eta = np.asarray(eta, dtype=float)[..., None]
    return 0.25 * (1.0 + _CORNERS[:, 0] * xi) * (1.0 + _CORNERS[:, 1] * eta)


def _grid(nx: int, ny: int) -> list[tuple[float, float, float, float]]:
    xs = np.linspace(-1.0, 1.0, nx + 1)
    ys = np.linspace(-1.0, 1.0, ny + 1)
    return [(xs[i], xs[i + 1], ys[j], ys[j + 1]) for j in range(ny) for i in range(nx)]


def smoothing_cells(sd: int) -> list[tuple[float, float, float, float]]:
    """Smoothing cells of one element as parent rectangles (xi0, xi1, eta0, eta1)."""
    layouts = {
        1: _grid(1, 1),
        2: _grid(2, 1),
        3: [(-1.0, 0.0, -1.0, 1.0), (0.0, 1.0, -1.0, 0.0), (0.0, 1.0, 0.0, 1.0)],
        4: _grid(2, 2),
        8: _grid(4, 2),
        16: _grid(4, 4),
    }
    if sd not in layouts:
        raise InputError(f"sd = {sd} is not supported: choose one of {list(layouts)}")
    return layouts[sd]


def element_areas(xe: np.ndarray) -> np.ndarray:
    """Signed areas (shoelace) of quadrilaterals xe (n, 4, 2); positive when counter-clockwise."""
    return polygon_areas(xe)


def b_from_gradients(bx: np.ndarray, by: np.ndarray) -> np.ndarray:
    """Assemble B (n, 3, 8) from shape-function x/y derivatives bx, by (n, 4)."""
    n = bx.shape[0]
    b = np.zeros((n, 3, 8))
    b[:, 0, 0::2] = bx
    b[:, 1, 1::2] = by
    b[:, 2, 0::2] = by
    b[:, 2, 1::2] = bx
    return b


def parent_derivatives(xi: float, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Derivatives (dN/dxi (4,), dN/deta (4,)) of the Q4 shape functions at a parent point."""
    return (0.25 * _CORNERS[:, 0] * (1.0 + _CORNERS[:, 1] * eta),
            0.25 * _CORNERS[:, 1] * (1.0 + _CORNERS[:, 0] * xi))


def gauss_points() -> list[tuple[float, float]]:
    """The 2x2 Gauss points (xi, eta) of FEM-Q4, xi fastest; every weight is 1."""
    g = 1.0 / np.sqrt(3.0)
    return [(a, b) for b in (-g, g) for a in (-g, g)]


def gauss_gradients(xe: np.ndarray, xi: float, eta: float
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """FEM-Q4 shape-function gradients at one parent point: (bx (n, 4), by (n, 4), detJ)."""
    dn_dxi, dn_deta = parent_derivatives(xi, eta)
    j11 = xe[..., 0] @ dn_dxi
    j12 = xe[..., 1] @ dn_dxi
    j21 = xe[..., 0] @ dn_deta
    j22 = xe[..., 1] @ dn_deta
    det = j11 * j22 - j12 * j21
    inv = 1.0 / det
    bx = (j22 * inv)[:, None] * dn_dxi - (j12 * inv)[:, None] * dn_deta
    by = (-j21 * inv)[:, None] * dn_dxi + (j11 * inv)[:, None] * dn_deta
    return bx, by, det


def smoothing_tables(cells: list) -> tuple[np.ndarray, np.ndarray]:
    """Shape functions of the element's 4 nodes at the smoothing cells' corners and edges.

    cells: parent rectangles (xi0, xi1, eta0, eta1). Returns (ncorner, nmid), both
    (nc, 4, 4): ncorner[c, k, a] = N_a at corner k of cell c (counter-clockwise),
    nmid[c, k, a] = N_a at the midpoint of edge k (corner k to corner k + 1).
    """
    corners = np.array([[[c[0], c[2]], [c[1], c[2]], [c[1], c[3]], [c[0], c[3]]]
                        for c in cells])  # (nc, 4, 2) parent corners, counter-clockwise
    mids = 0.5 * (corners + np.roll(corners, -1, axis=1))
    return (shape_functions(corners[..., 0], corners[..., 1]),
            shape_functions(mids[..., 0], mids[..., 1]))


def smoothed_gradients(xe: np.ndarray, cells: list) -> tuple:
    """Smoothed shape-function gradients of every smoothing cell of every element.

    xe: (n, 4, 2) element corners; cells: parent rectangles (xi0, xi1, eta0, eta1).
    On cell k with area A_k: b_I = (1/A_k) sum_edges l n N_I at the edge midpoint (the
    boundary integral; exact since N_I is linear along the straight cell edges).
    Returns (bx, by (n, nc, 4), areas (n, nc)).
    """
    nc = len(cells)
    ncorner, nmid = smoothing_tables(cells)
    xc = np.matmul(ncorner.reshape(nc * 4, 4), xe).reshape(-1, nc, 4, 2)  # cell corners
    d = np.roll(xc, -1, axis=2) - xc  # edge vectors (n, nc, 4, 2)
    area = polygon_areas(xc)
    inv_a = (1.0 / area)[..., None]
    # l n_x = dy and l n_y = -dx on a counter-clockwise boundary
    bx = np.einsum("nce,cea->nca", d[..., 1], nmid, optimize=True) * inv_a
    by = -np.einsum("nce,cea->nca", d[..., 0], nmid, optimize=True) * inv_a
    return bx, by, area


def stiffness_blocks(bx: np.ndarray, by: np.ndarray, w: np.ndarray, d: np.ndarray,
                     thickness: float = 1.0
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Element stiffness as four (n, 4, 4) node blocks (K_uu, K_uv, K_vu, K_vv).

    bx, by: (n, nc, 4) cell gradients; w: (n, nc) weights; d: (n, 3, 3) elasticity with
    d13 = d23 = 0 (isotropic, plane strain or stress). K_uu[a, b] is the entry of
    (u_a, u_b), K_uv[a, b] of (u_a, v_b) and so on; the same numbers as
    t * sum_c w_c B_c^T D B_c with B_c from `methods.strain_matrices`.
    """
    bxw = bx * (w * thickness)[..., None]
    byw = by * (w * thickness)[..., None]
    xx = np.matmul(bxw.transpose(0, 2, 1), bx)
    yy = np.matmul(byw.transpose(0, 2, 1), by)
    xy = np.matmul(bxw.transpose(0, 2, 1), by)
    yx = xy.transpose(0, 2, 1)
    d11, d12, d33 = d[:, 0, 0, None, None], d[:, 0, 1, None, None], d[:, 2, 2, None, None]
    d22 = d[:, 1, 1, None, None]
    return (d11 * xx + d33 * yy, d12 * xy + d33 * yx, d12 * yx + d33 * xy,
            d22 * yy + d33 * xx)


def elasticity_matrix(E: ArrayLike, nu: ArrayLike, plane: str = "strain") -> np.ndarray:
    """Isotropic elasticity matrices D, shape (..., 3, 3), for arrays of E and nu."""
    E = np.asarray(E, dtype=float)
    nu = np.asarray(nu, dtype=float)
    d = np.zeros(E.shape + (3, 3))
    if plane == "strain":
        f = E / ((1.0 + nu) * (1.0 - 2.0 * nu))
        d[..., 0, 0] = d[..., 1, 1] = f * (1.0 - nu)
        d[..., 0, 1] = d[..., 1, 0] = f * nu
        d[..., 2, 2] = f * (1.0 - 2.0 * nu) / 2.0
    elif plane == "stress":
        f = E / (1.0 - nu**2)
        d[..., 0, 0] = d[..., 1, 1] = f
        d[..., 0, 1] = d[..., 1, 0] = f * nu
        d[..., 2, 2] = f * (1.0 - nu) / 2.0
    else:
        raise InputError(f"analysis.plane = '{plane}': use 'strain' or 'stress'")
    return d


def cell_strains(b: np.ndarray, ue: np.ndarray) -> np.ndarray:
    """Strains per cell (n, nc, 3) from element displacements ue (n, 8)."""
    return np.einsum("ncia,na->nci", b, ue, optimize=True)
