"""FEM-Q4: bilinear quadrilaterals with 2x2 Gauss integration (the reference method)."""

from __future__ import annotations

import numpy as np

from app.discretisation.elements import gauss_gradients, gauss_points, parent_derivatives


def cell_gradients(xe: np.ndarray, sd: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(bx, by (n, 4, 4), det J x Gauss weight (n, 4)) at the 2x2 Gauss points; sd unused."""
    parts = [gauss_gradients(xe, a, b) for a, b in gauss_points()]
    return tuple(np.stack([p[k] for p in parts], axis=1) for k in range(3))


def cell_operators(sd: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The compiled kernel's constants at the Gauss points: det J = x^T S y with S = T."""
    pts = gauss_points()
    dxi, deta = (np.array([parent_derivatives(a, b)[k] for a, b in pts]) for k in (0, 1))
    tops = np.einsum("ga,gb->gab", dxi, deta) - np.einsum("ga,gb->gab", deta, dxi)
    return tops, tops, np.ones(len(pts))
