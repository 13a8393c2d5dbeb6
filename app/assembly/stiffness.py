"""Distributed assembly of the global stiffness into a PETSc AIJ matrix.

Each rank owns a contiguous block of nodes (and so of DOFs 2*node + component), computes
the element matrices of the elements touching its nodes, and builds the CSR rows of its
own block. No rank ever holds the global matrix. Two routes give the same matrix:
- compiled (the default when app/assembly/_kernel.c was built): the C kernel of
  app/assembly/compiled.py builds the rows, and PETSc takes the arrays without copying
  them (MatCreateSeqAIJWithArrays, or MatCreateMPIAIJWithSplitArrays through ctypes);
- numpy (the reference, and the fallback without the kernel): sort + bincount, no
  Python loop over elements, and PETSc copies the CSR.
"""

from __future__ import annotations

import ctypes

import numpy as np
from petsc4py import PETSc

from app.assembly import compiled
from app.discretisation.bulk import Discretisation, element_blocks
from app.mesh.model import Mesh
from app.petsc_lib import PETSC_INT, load_petsc, mpi_comm_handle


def node_ownership(n_nodes: int, size: int) -> np.ndarray:
    """First node of every rank's contiguous block, shape (size + 1,)."""
    counts = np.full(size, n_nodes // size, dtype=np.int64)
    counts[: n_nodes % size] += 1
    return np.concatenate([[0], np.cumsum(counts)])


def assemble_stiffness(mesh: Mesh, disc: Discretisation, comm=None,
                       route: str = "auto") -> PETSc.Mat:
    """Assemble the global stiffness as a distributed PETSc AIJ matrix.

    Rows/columns are DOFs 2*node + component; rank r owns nodes
    node_ownership(n_nodes, size)[r:r+2]. route: "compiled", "numpy", or "auto" (compiled
    when the kernel is built and, on several ranks, the PETSc library loads through ctypes).
    """
    comm = comm or PETSc.COMM_WORLD
    rank, size = comm.getRank(), comm.getSize()
    own = node_ownership(mesh.n_nodes, size)
    n0, n1 = int(own[rank]), int(own[rank + 1])
    if route not in ("auto", "compiled", "numpy"):
        raise ValueError(f"route = {route!r}: use 'auto', 'compiled' or 'numpy'")
    if route == "auto":
        ready = compiled.kernel() is not None and (size == 1 or _split_arrays_available())
        route = "compiled" if ready else "numpy"
    if route == "compiled":
        csr = compiled.local_stiffness(mesh, disc, n0, n1, PETSc.IntType)
        return petsc_matrix(csr, 2 * mesh.n_nodes, comm)
    return _assemble_numpy(mesh, disc, comm, n0, n1)


def _split_arrays_available() -> bool:
    lib = load_petsc()
    return lib is not None and all(
        hasattr(lib, name) for name in ("MatCreateMPIAIJWithSplitArrays", "MatHeaderReplace"))


def petsc_matrix(csr: compiled.SplitCSR, n_glob: int, comm) -> PETSc.Mat:
    """An assembled AIJ matrix on `comm` that uses the arrays of `csr` without a copy.

    The arrays are attached to the matrix and live as long as it does; PETSc may rewrite
    csr.oind in place (to its compressed off-diagonal columns).
    """
    m = 2 * (csr.n1 - csr.n0)
    if comm.getSize() == 1:
        return PETSc.Mat().createAIJWithArrays(size=((m, n_glob), (m, n_glob)),
                                               csr=(csr.dptr, csr.dind, csr.dval), comm=comm)
    lib = load_petsc()
    ptr = ctypes.c_void_p
    handle = ptr()
    arrays = (csr.dptr, csr.dind, csr.dval, csr.optr, csr.oind, csr.oval)
    err = lib.MatCreateMPIAIJWithSplitArrays(
        mpi_comm_handle(comm), PETSC_INT(m), PETSC_INT(m), PETSC_INT(n_glob),
        PETSC_INT(n_glob), *(ptr(a.ctypes.data) for a in arrays), ctypes.byref(handle))
    if err:
        raise RuntimeError(f"MatCreateMPIAIJWithSplitArrays failed (PETSc error {err})")
    # Move the new matrix into a petsc4py object: MatHeaderReplace swaps the headers
    # and destroys the emptied one.
    mat = PETSc.Mat().create(comm=comm)
    err = lib.MatHeaderReplace(ptr(mat.handle), ctypes.byref(handle))
    if err:
        raise RuntimeError(f"MatHeaderReplace failed (PETSc error {err})")
    mat.setAttr("__split_csr__", arrays)
    return mat


def _assemble_numpy(mesh: Mesh, disc: Discretisation, comm, n0: int, n1: int) -> PETSc.Mat:
    """The reference route: numpy sort + bincount, PETSc copies the CSR."""
    n_nodes = mesh.n_nodes
    uniq, inv, vals = _node_pair_entries(mesh, disc, n0, n1)
    n_local = n1 - n0
    indptr, indices, data = _block_csr(uniq, inv, vals, n_nodes, n_local)
    n_glob = 2 * n_nodes
    mat = PETSc.Mat().createAIJ(
        size=((2 * n_local, n_glob), (2 * n_local, n_glob)),
        csr=(indptr, indices, data),
        comm=comm,
    )
    mat.assemble()
    return mat


def _node_pair_entries(mesh: Mesh, disc: Discretisation, n0: int,
                       n1: int) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """Element-matrix entries of the node pairs (a, b) whose row node a is in [n0, n1).

    Returns uniq (P,) sorted keys (a - n0) * n_nodes + b of the distinct pairs, inv (E,)
    the key index of every entry, and vals: 4 arrays (E,), the uu, uv, vu, vv values of
    the entries (to be summed per key).
    """
    n_nodes = mesh.n_nodes
    quads = mesh.quads
    touches = np.any((quads >= n0) & (quads < n1), axis=1)
    elements = np.flatnonzero(touches)
    kb = element_blocks(mesh, disc, elements)  # 4 x (ne, 4, 4): uu, uv, vu, vv
    conn = quads[elements]  # (ne, 4)

    # Node-pair entries (a, b) of every element whose row node lies in [n0, n1).
    rows = np.repeat(conn, 4, axis=1)  # (ne, 16): a-major
    cols = np.tile(conn, (1, 4))
    keep = (rows >= n0) & (rows < n1)
    pair = np.arange(16)
    if keep.all():  # one rank, or every touching element entirely owned
        key = ((rows - n0).astype(np.int64) * n_nodes + cols).ravel()
        uniq, inv = np.unique(key, return_inverse=True)
        sel = (slice(None), pair // 4, pair % 4)
        vals = [kb[k][sel].ravel() for k in range(4)]
    else:
        e_idx, p_idx = np.nonzero(keep)
        key = (rows[e_idx, p_idx] - n0).astype(np.int64) * n_nodes + cols[e_idx, p_idx]
        uniq, inv = np.unique(key, return_inverse=True)
        vals = [kb[k][e_idx, p_idx // 4, p_idx % 4] for k in range(4)]
    return uniq, inv, vals


def _block_csr(uniq: np.ndarray, inv: np.ndarray, vals: list[np.ndarray], n_nodes: int,
               n_local: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scalar CSR (indptr, indices, data) of the n_local owned nodes' DOF rows from the
    node-pair entries of `_node_pair_entries` (2x2 blocks summed per pair, column-sorted)."""
    n_pairs = uniq.size
    # 2x2 block values of each entry, summed into the unique node pairs.
    blocks = np.empty((n_pairs, 2, 2))
    for k in range(4):
        blocks[:, k // 2, k % 2] = np.bincount(inv, weights=vals[k], minlength=n_pairs)
    row_node = uniq // n_nodes  # local node index, sorted
    col_node = uniq % n_nodes
    per_node = np.bincount(row_node, minlength=n_local)  # neighbours per local node
    # Scalar CSR: rows 2I and 2I+1 each hold 2 * per_node[I] entries.
    row_len = np.repeat(2 * per_node, 2)
    indptr = np.concatenate([[0], np.cumsum(row_len)]).astype(PETSc.IntType)
    start = np.concatenate([[0], np.cumsum(per_node)[:-1]])  # first pair of each node
    # For pair k of node I (position p = k - start[I]): row 2I entries at
    # indptr[2I] + 2p + (0, 1), row 2I+1 at indptr[2I+1] + 2p + (0, 1).
    p = np.arange(n_pairs) - start[row_node]
    base0 = indptr[2 * row_node] + 2 * p
    base1 = indptr[2 * row_node + 1] + 2 * p
    nnz = int(indptr[-1])
    indices = np.empty(nnz, dtype=PETSc.IntType)
    data = np.empty(nnz)
    indices[base0] = 2 * col_node
    indices[base0 + 1] = 2 * col_node + 1
    indices[base1] = 2 * col_node
    indices[base1 + 1] = 2 * col_node + 1
    data[base0] = blocks[:, 0, 0]
    data[base0 + 1] = blocks[:, 0, 1]
    data[base1] = blocks[:, 1, 0]
    data[base1 + 1] = blocks[:, 1, 1]
    return indptr, indices, data
