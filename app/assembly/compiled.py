"""Compiled stiffness assembly: one rank's CSR rows from the C kernel in _kernel.c.

The kernel is a shared library built by `pip install -e .` (setup.py) and called through
ctypes on raw numpy buffers. It builds the node graph of the rank's rows directly from
the quad connectivity (no global sort), computes every element's node blocks and adds
them straight into the CSR values. `kernel()` is None when the library was not built;
app/assembly/stiffness.py then uses its numpy route.

The rows come split the way PETSc's MatCreateMPIAIJWithSplitArrays takes them (see
`SplitCSR`), so that no copy is needed on any number of ranks.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass

import numpy as np
from numpy.ctypeslib import ndpointer

from app.discretisation.bulk import Discretisation
from app.discretisation.elements import elasticity_matrix
from app.discretisation.methods import bulk_method
from app.errors import InputError
from app.mesh.model import Mesh
from app.petsc_lib import built_library

_I64 = ndpointer(np.int64, flags="C_CONTIGUOUS")
_I32 = ndpointer(np.int32, flags="C_CONTIGUOUS")
_F64 = ndpointer(np.float64, flags="C_CONTIGUOUS")
_INT_TYPES = {np.dtype(np.int32): "i32", np.dtype(np.int64): "i64"}
_LIB: ctypes.CDLL | None = None
_TRIED = False


def kernel() -> ctypes.CDLL | None:
    """The compiled kernel library with its argument types declared, or None if not built."""
    global _LIB, _TRIED
    if not _TRIED:
        _TRIED = True
        lib = built_library("app.assembly._kernel")
        try:
            _LIB = None if lib is None else _declare(lib)
        except AttributeError:  # an older build without every function
            _LIB = None
    return _LIB


def _declare(lib: ctypes.CDLL) -> ctypes.CDLL:
    i64 = ctypes.c_int64
    lib.csfem_incidence_count.argtypes = [i64, _I64, i64, i64, _I32]
    lib.csfem_incidence_count.restype = i64
    lib.csfem_incidence_fill.argtypes = [i64, _I64, i64, i64, _I32, _I32, _I32]
    lib.csfem_incidence_fill.restype = None
    for dtype, suffix in _INT_TYPES.items():
        ind = ndpointer(dtype, flags="C_CONTIGUOUS")
        graph = [i64, i64, i64, _I64, _I32, _I32, _I32]
        functions = {
            "graph_ptr": graph + [ind, ind],
            "graph_ind": graph + [ind] * 4,
            "add_blocks": [i64, _I64, _F64, _I64, _F64, ctypes.c_double, ctypes.c_int, _F64,
                           _F64, _F64, i64, i64, ind, ind, _F64, ind, ind, _F64],
        }
        for name, argtypes in functions.items():
            f = getattr(lib, f"csfem_{name}_{suffix}")
            f.argtypes, f.restype = argtypes, ctypes.c_int
    return lib


def _indices(a: np.ndarray, bound: int, what: str) -> np.ndarray:
    """a as a contiguous int64 array, checked to lie in [0, bound) (the kernel trusts it)."""
    a = np.ascontiguousarray(a, dtype=np.int64)
    if a.size and (a.min() < 0 or a.max() >= bound):
        raise InputError(f"{what} has indices outside [0, {bound})")
    return a


def _check(status: int, what: str) -> None:
    if status == -1:
        raise MemoryError(f"compiled assembly: out of memory in {what}")
    if status == -3:
        raise InputError("the stiffness has too many entries on this rank for the PETSc "
                         "index type: use more ranks or 64-bit PETSc indices")
    if status != 0:
        raise RuntimeError(f"compiled assembly: {what} failed (status {status})")


@dataclass
class SplitCSR:
    """One rank's rows of the stiffness, DOFs 2*node + component, rank owns [n0, n1).

    Both parts have 2 (n1 - n0) rows with sorted columns. The diagonal part (dptr, dind,
    dval) holds the columns of owned nodes as local DOF indices 2*(node - n0) + c; the
    off-diagonal part (optr, oind, oval) the other columns as global DOF indices. Row
    pointers and indices have the PETSc integer type; values are in force / length.
    """

    n0: int
    n1: int
    dptr: np.ndarray  # (2 (n1 - n0) + 1,)
    dind: np.ndarray  # (nnz_d,)
    dval: np.ndarray  # (nnz_d,)
    optr: np.ndarray  # (2 (n1 - n0) + 1,)
    oind: np.ndarray  # (nnz_o,)
    oval: np.ndarray  # (nnz_o,)


def node_graph(quads: np.ndarray, n0: int, n1: int, n_nodes: int,
               int_type=np.int32) -> SplitCSR:
    """Sparsity of the rows of nodes [n0, n1) of a mesh of n_nodes nodes, values zero.

    quads: (ne, 4) node indices. Node I's row couples it with every node that shares an
    element with it (I included), as 2x2 blocks.
    """
    lib = kernel()
    if lib is None:
        raise RuntimeError("the compiled assembly kernel is not built: run scripts/setup.sh")
    int_type = np.dtype(int_type)
    if int_type not in _INT_TYPES:
        raise InputError(f"index type {int_type} is not supported by the compiled assembly")
    quads = _indices(quads, n_nodes, "quads")
    ne, nl = len(quads), n1 - n0
    if 4 * ne >= 2**31 or 2 * n_nodes > np.iinfo(int_type).max:
        raise InputError("the mesh is too large for the compiled assembly's index types")
    if not 0 <= n0 <= n1 <= n_nodes:
        raise InputError(f"node range [{n0}, {n1}) is not inside [0, {n_nodes})")
    # Node -> element incidence of the owned nodes (CSR), then the rows.
    eptr = np.empty(nl + 1, dtype=np.int32)
    elist = np.empty(max(lib.csfem_incidence_count(ne, quads, n0, n1, eptr), 1), np.int32)
    work = np.empty(max(n_nodes, 1), dtype=np.int32)
    lib.csfem_incidence_fill(ne, quads, n0, n1, eptr, elist, work)
    suffix = _INT_TYPES[int_type]
    graph = (n0, n1, n_nodes, quads, eptr, elist, work)
    dptr, optr = np.empty(2 * nl + 1, dtype=int_type), np.empty(2 * nl + 1, dtype=int_type)
    _check(getattr(lib, f"csfem_graph_ptr_{suffix}")(*graph, dptr, optr), "graph pointers")
    nnz_d, nnz_o = int(dptr[-1]), int(optr[-1])
    g = SplitCSR(n0, n1, dptr, np.empty(nnz_d, dtype=int_type), np.zeros(nnz_d),
                 optr, np.empty(nnz_o, dtype=int_type), np.zeros(nnz_o))
    _check(getattr(lib, f"csfem_graph_ind_{suffix}")(*graph, dptr, optr, g.dind, g.oind),
           "graph indices")
    return g


def cell_operators(method: str, sd: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The kernel's constant operators of the cells of one element: (tops, sops, gw).

    For the element's node coordinates x, y (4 each) and cell c: measure
    m_c = x^T S_c y (cell area, or det J at a Gauss point), gradients
    bx_c = (T_c y) / m_c and by_c = -(T_c x) / m_c, weight w_c = gw_c m_c. Returns
    tops = T (nc, 4, 4), sops = the upper triangle (S01, S02, S03, S12, S13, S23) of the
    antisymmetric S (nc, 6), gw (nc,). The same numbers as `cell_gradients`:
    CS-FEM's boundary integral at the cell edge midpoints is linear in y (in x for by),
    and the shoelace area and det J are bilinear in (x, y). The constants come from the
    method's registry entry (app/discretisation/methods.py).
    """
    tops, sfull, gw = bulk_method(method, "method").cell_operators(sd)
    upper = np.triu_indices(4, 1)
    return tops, np.ascontiguousarray(sfull[:, upper[0], upper[1]]), gw


def add_element_blocks(g: SplitCSR, points: np.ndarray, quads: np.ndarray, body: np.ndarray,
                       d: np.ndarray, thickness: float, method: str, sd: int) -> None:
    """Add K_e of every element touching nodes [g.n0, g.n1) into g.dval and g.oval.

    points (n_nodes, 2), quads (ne, 4), body (ne,) body index of each element,
    d (n_bodies, 3, 3) isotropic elasticity (d13 = d23 = 0) per body.
    """
    lib = kernel()
    tops, sops, gw = (np.ascontiguousarray(a, dtype=float) for a in cell_operators(method, sd))
    dmat = np.ascontiguousarray(d[:, [0, 0, 1, 2], [0, 1, 1, 2]], dtype=float)
    points = np.ascontiguousarray(points, dtype=float)
    if points.shape[1:] != (2,) or len(body) != len(quads):
        raise InputError("points must be (n_nodes, 2) and body one index per element")
    quads = _indices(quads, len(points), "quads")
    body = _indices(body, len(dmat), "body")
    add = getattr(lib, f"csfem_add_blocks_{_INT_TYPES[g.dptr.dtype]}")
    status = add(len(quads), quads, points, body, dmat, float(thickness), len(gw), tops, sops,
                 gw, g.n0, g.n1, g.dptr, g.dind, g.dval, g.optr, g.oind, g.oval)
    _check(status, "element blocks")


def local_stiffness(mesh: Mesh, disc: Discretisation, n0: int, n1: int,
                    int_type=np.int32) -> SplitCSR:
    """The stiffness rows of nodes [n0, n1) (thickness included), without MPI."""
    g = node_graph(mesh.quads, n0, n1, mesh.n_nodes, int_type)
    d = elasticity_matrix(disc.E, disc.nu, disc.plane)
    add_element_blocks(g, mesh.points, mesh.quads, mesh.body, d, disc.thickness,
                       disc.method, disc.sd)
    return g
