"""The PETSc shared library through ctypes, for the few calls petsc4py 3.18 does not wrap.

petsc4py has already loaded the library, so opening it again by name returns the same
copy. Used by the Schur-complement route (app/condensation/compliance.py) and the
compiled assembly (app/assembly/compiled.py). Also `built_library`: the project's own
optional C parts built by setup.py (the assembly kernel, app/_hard_stop.c).
"""

from __future__ import annotations

import ctypes
import importlib.util

import numpy as np
from petsc4py import PETSc

# The C type of PetscInt (32-bit unless PETSc was configured with 64-bit indices).
PETSC_INT = ctypes.c_int64 if np.dtype(PETSc.IntType) == np.int64 else ctypes.c_int32

_LIB: ctypes.CDLL | None = None


def load_petsc() -> ctypes.CDLL | None:
    """The PETSc shared library, or None when none of the usual names can be opened."""
    global _LIB
    if _LIB is None:
        for name in ("libpetsc_real.so.3.18", "libpetsc_real.so", "libpetsc.so"):
            try:
                _LIB = ctypes.CDLL(name)
                break
            except OSError:
                continue
    return _LIB


def built_library(module: str) -> ctypes.CDLL | None:
    """The shared library setup.py built for `module` (e.g. "app._hard_stop"), opened
    through ctypes; None when it was not built (no C compiler) or cannot be opened."""
    spec = importlib.util.find_spec(module)
    if spec is None or spec.origin is None:
        return None
    try:
        return ctypes.CDLL(spec.origin)
    except OSError:
        return None


def mpi_comm_handle(comm: PETSc.Comm) -> ctypes.c_void_p | ctypes.c_int:
    """The C MPI_Comm of a petsc4py communicator, as a ctypes argument.

    A pointer with Open MPI, an int with MPICH.
    """
    from mpi4py import MPI

    handle = MPI._handleof(comm.tompi4py())
    if MPI._sizeof(MPI.Comm) == ctypes.sizeof(ctypes.c_void_p):
        return ctypes.c_void_p(handle)
    return ctypes.c_int(handle)
