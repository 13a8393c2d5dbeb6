"""Memory of the dense contact matrices, checked once the pairs are known (before the
factorization that forms them).

The condensation keeps dense matrices on rank 0 whose size grows with the square of the
contact, not with the mesh: the Schur complement S on the n_c free DOFs that G touches
(with its factor and the copies made while reading it) and the compliance C and LCP
matrix on the 2m rows of G. The size estimate before meshing (app/mesh/estimate.py)
counts elements; a thin body with a long contact passes it and then asked for S at once:
`patch.toml` with both blocks `divisions = [8000, 1]` (64,000 DOFs) stopped after a
minute with numpy's "Unable to allocate 7.63 GiB" traceback, and 16,000 would need about
100 GB. Measured on `divisions = [2000, 1]` (n_c = 8,000, 2m = 4,002): 1.67 GB above the
rest of the run at the compliance phase, against 1.92 GB from DENSE_BYTES below.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from app.condensation.compliance import contact_dofs
from app.condensation.contact_columns import column_cap
from app.errors import InputError

DENSE_BYTES = 24.0
"""Bytes per entry of n_c^2 + (2m)^2: float64 times the copies alive at the peak (3)."""


def free_contact_dofs(g: sp.spmatrix, fixed: np.ndarray) -> int:
    """n_c: the free (not prescribed) DOFs that a row of G touches with a non-zero weight
    (the compliance's `contact_dofs`)."""
    return int(contact_dofs(sp.csr_matrix(g, copy=True), fixed)[0].size)


def dense_contact_bytes(n_contact_dofs: int, n_rows: int) -> float:
    """Peak bytes of the dense contact matrices on rank 0 (S, C, the LCP matrix) and of
    the recovery's kept columns S^-1 G_c^T (app/condensation/contact_columns.py), which
    stay through the steps: on cattaneo_many they raised the compliance peak 34 MB above
    the DENSE_BYTES term's 2% margin."""
    kept = 8.0 * n_contact_dofs * column_cap(n_contact_dofs, n_rows)
    return DENSE_BYTES * (float(n_contact_dofs) ** 2 + float(n_rows) ** 2) + kept


def check_dense_contact(g: sp.spmatrix, fixed: np.ndarray, other_bytes: float,
                        available: float, allow_large: bool = False) -> float:
    """InputError (one line) when the dense contact matrices plus `other_bytes` (the rest
    of the run) exceed `available` bytes, unless allow_large; returns their bytes."""
    n_c = free_contact_dofs(g, fixed)
    need = dense_contact_bytes(n_c, g.shape[0])
    if not allow_large and need + other_bytes > available:
        raise InputError(
            f"the contact has {g.shape[0] // 2} pairs on {n_c} free DOFs: its dense Schur "
            f"complement and compliance (rank 0) would need about {need / 1e9:.3g} GB, more "
            f"than this machine's {available / 1e9:.3g} GB of memory with the rest of the "
            "run: use coarser contact curves (mesh.size, the bodies' size or divisions), a "
            "smaller search_distance, or --allow-large to run anyway")
    return need
