"""The BLAS threads of a run: chosen before numpy loads, recorded in summary.json.

numpy's wheel brings its own OpenBLAS (numpy.libs/libopenblas64_p-*.so, pthreads) and
PETSc / MUMPS load Debian's (openblas-pthread/libopenblasp-r0.3.21.so): two libraries,
each of which reads OPENBLAS_NUM_THREADS (else OMP_NUM_THREADS) once, when it loads, and
otherwise starts one thread a core of the process's CPU affinity. Under Open MPI's
`mpiexec -n 2` each rank is bound to one core, so that is one thread a rank; with
`--bind-to none`, `--oversubscribe` or a launcher that does not bind (MPICH's hydra),
every rank starts one a core: 4 threads on 2 cores for 2 ranks.

`choose()` (app/__main__.py, before any module that imports numpy): when the user set
none of OPENBLAS_NUM_THREADS / OMP_NUM_THREADS / MKL_NUM_THREADS and the process is one
of several ranks on its node (OMPI_COMM_WORLD_LOCAL_SIZE, MPI_LOCALNRANKS, else the world
size OMPI_COMM_WORLD_SIZE / PMI_SIZE), it sets OPENBLAS_NUM_THREADS and OMP_NUM_THREADS
to max(1, cores // ranks); on one rank it leaves the libraries' default (one thread a
core: not slower, README "Timings"); a user's setting always wins. `record()` is the
`blas_threads` entry of summary.json's provenance. Stdlib only.
"""

from __future__ import annotations

import ctypes
import os
from collections.abc import MutableMapping

THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
LOCAL_SIZE_VARS = ("OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS")
WORLD_SIZE_VARS = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE")

_chosen: dict = {"set_by": "not chosen (app/__main__.py did not start this process)"}


def _ranks_on_node(environ: MutableMapping[str, str]) -> int:
    """The ranks sharing this node, as the MPI launcher's environment tells (1 if none)."""
    for name in LOCAL_SIZE_VARS + WORLD_SIZE_VARS:
        value = environ.get(name, "").strip()
        if value.isdigit() and int(value) > 0:
            return int(value)
    return 1


def choose(environ: MutableMapping[str, str] = os.environ,
           cores: int | None = None) -> dict:
    """Sets the BLAS thread variables in `environ` when nobody did and several ranks
    share the node; returns (and keeps for `record`) what was decided. cores: the
    machine's cores (default os.cpu_count())."""
    global _chosen
    user = {k: environ[k] for k in THREAD_VARS if environ.get(k, "").strip()}
    ranks = _ranks_on_node(environ)
    if user:
        _chosen = {"set_by": "user", "variables": user, "ranks_on_node": ranks}
        return _chosen
    if ranks <= 1:
        _chosen = {"set_by": "library default (one thread a core)", "ranks_on_node": 1}
        return _chosen
    threads = max(1, (cores or os.cpu_count() or 1) // ranks)
    environ["OPENBLAS_NUM_THREADS"] = environ["OMP_NUM_THREADS"] = str(threads)
    _chosen = {"set_by": "app (cores // ranks on the node)", "ranks_on_node": ranks,
               "variables": {"OPENBLAS_NUM_THREADS": str(threads),
                             "OMP_NUM_THREADS": str(threads)}}
    return _chosen


def loaded_openblas_threads() -> dict[str, int]:
    """Each OpenBLAS library loaded in this process (file name) -> the threads it uses
    (openblas_get_num_threads); {} where /proc/self/maps is not there."""
    try:
        with open("/proc/self/maps") as maps:
            fields = (line.rstrip("\n").split(maxsplit=5) for line in maps)
            paths = {f[5] for f in fields  # (the path: the 6th field, spaces and all)
                     if len(f) == 6 and "openblas" in os.path.basename(f[5]).lower()}
    except OSError:
        return {}
    counts = {}
    for path in sorted(p for p in paths if p.startswith("/")):
        try:
            lib = ctypes.CDLL(path, mode=os.RTLD_NOLOAD | os.RTLD_LAZY)
        except OSError:
            continue
        for symbol in ("openblas_get_num_threads64_", "openblas_get_num_threads"):
            if hasattr(lib, symbol):
                counts[os.path.basename(path)] = int(getattr(lib, symbol)())
                break
    return counts


def record() -> dict:
    """summary.json's `provenance.blas_threads`: `threads` (the most any loaded OpenBLAS
    uses; None if none found), `libraries` (each one's), who set it and the variables."""
    libraries = loaded_openblas_threads()
    return {"threads": max(libraries.values()) if libraries else None,
            "libraries": libraries, **_chosen}
