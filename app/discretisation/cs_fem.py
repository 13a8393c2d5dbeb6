"""CS-FEM: cell-based smoothed strains over 1, 2, 3, 4, 8 or 16 smoothing cells per Q4.

The smoothed gradient of a cell is its boundary integral of n N_I, one point per straight
edge (`elements.smoothed_gradients`); no shape-function derivatives are used.
"""

from __future__ import annotations

import numpy as np

from app.discretisation.elements import smoothed_gradients, smoothing_cells, smoothing_tables

SMOOTHING_DOMAINS = (1, 2, 3, 4, 8, 16)


def cell_gradients(xe: np.ndarray, sd: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(bx, by (n, sd, 4), cell areas (n, sd)) of elements xe (n, 4, 2), relative corners."""
    return smoothed_gradients(xe, smoothing_cells(sd))


def cell_operators(sd: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The compiled kernel's constants (T (nc, 4, 4), S (nc, 4, 4) antisymmetric, gw (nc,)).

    For corners x, y of an element: cell area m_c = x^T S_c y, bx_c = (T_c y) / m_c,
    by_c = -(T_c x) / m_c, weight gw_c m_c (see app/assembly/compiled.py).
    """
    ncorner, nmid = smoothing_tables(smoothing_cells(sd))  # (nc, 4, 4) each
    edge = np.roll(ncorner, -1, axis=1) - ncorner  # corner k+1 minus corner k
    tops = np.einsum("cea,ceb->cab", nmid, edge)
    s = 0.5 * np.einsum("cka,ckb->cab", ncorner, np.roll(ncorner, -1, axis=1))
    return tops, s - s.transpose(0, 2, 1), np.ones(len(tops))
