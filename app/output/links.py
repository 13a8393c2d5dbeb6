"""Arrays that repeat from step to step, written once (app/output/xdmf.py).

A step's dataset whose bytes equal those of the last written copy of the same name (the
same dtype, shape and bits) is written as an HDF5 external link to that copy: a file name
relative to the output folder and a path in it (`h5py.ExternalLink`), so that
`f["/contact/g_cols"]` reads the same array from every step file and the folder can be
moved or copied whole. The copy is always a real dataset in a complete file (mesh.h5, or
a step file already renamed into place): links never point at a link, nor at a file that
is still being written. A dataset that changed is written again, and later steps link to
the new copy.

The stress components (`s_xx`, ... of `stress`) are HDF5 virtual datasets on the columns
of `/stress` in the same file (`column_dataset`).
"""

from __future__ import annotations

from dataclasses import dataclass

import h5py
import numpy as np

LINK_MIN_BYTES = 1024
"""Smaller arrays are always written: a link and its file name cost about as much."""


@dataclass(frozen=True)
class Column:
    """A virtual dataset: column `index` of the dataset `source` (shape (n, k), `dtype`)
    in the same file."""

    source: str
    index: int
    shape: tuple[int, int]
    dtype: np.dtype


@dataclass
class _Copy:
    fname: str  # the file holding the real dataset, relative to the output folder
    path: str  # its path in that file ("/contact/g_cols")
    step: int  # the step of that file (0: mesh.h5, written before step 1)
    data: np.ndarray  # a private copy of its values


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Bitwise equal (NaN equals NaN, -0.0 differs from 0.0), same dtype and shape."""
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    bits = [np.ascontiguousarray(v).reshape(-1).view(np.uint8) for v in (a, b)]
    return np.array_equal(*bits)


class SharedArrays:
    """The last written copy of every array by name, and the links to them."""

    def __init__(self) -> None:
        self.copies: dict[str, _Copy] = {}

    def seed(self, name: str, fname: str, path: str, data: np.ndarray, step: int = 0) -> None:
        """Record a real dataset already written completely (e.g. mesh.h5's /body)."""
        self.copies[name] = _Copy(fname, path, step, np.array(data, copy=True))

    def split(self, datasets: dict[str, object]) -> tuple[dict, dict[str, tuple[str, str]]]:
        """(datasets with the repeated arrays replaced by `h5py.ExternalLink`s, and for
        every linked name the (file, path) of its one copy: the XDMF points there)."""
        out, where = {}, {}
        for name, value in datasets.items():
            copy = self.copies.get(name)
            if isinstance(value, np.ndarray) and copy is not None and \
                    value.nbytes >= LINK_MIN_BYTES and _same(copy.data, value):
                out[name] = h5py.ExternalLink(copy.fname, copy.path)
                where[name] = (copy.fname, copy.path)
            else:
                out[name] = value
        return out, where

    def written(self, fname: str, step: int, datasets: dict[str, object]) -> None:
        """After `fname` (step `step`) is complete on disk: its real arrays become the
        copies later steps link to."""
        for name, value in datasets.items():
            if isinstance(value, np.ndarray) and value.nbytes >= LINK_MIN_BYTES \
                    and value.dtype.kind in "biuf":
                self.copies[name] = _Copy(fname, "/" + name, step, np.array(value, copy=True))

    def forget_after(self, n_steps: int) -> None:
        """Drop the copies in step files after `n_steps` (removed after a failed write)."""
        self.copies = {k: c for k, c in self.copies.items() if c.step <= n_steps}


def column_dataset(h5: h5py.File, name: str, col: Column) -> None:
    """Create `name` in `h5` as a virtual dataset on column col.index of col.source (same
    file, "."; the source may be a link). Its fill value is NaN: copied on its own to
    another file (h5py `copy`), where the source is missing, it reads NaN, not zeros."""
    layout = h5py.VirtualLayout(shape=col.shape[:1], dtype=col.dtype)
    layout[:] = h5py.VirtualSource(".", col.source, shape=col.shape)[:, col.index]
    fill = np.nan if np.dtype(col.dtype).kind == "f" else 0
    h5.create_virtual_dataset(name, layout, fillvalue=fill)
