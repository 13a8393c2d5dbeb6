"""Read back the contact pairs of a written step (`step_NNNN.h5`, group `/contact`).

One reader for the study, its references and the analysis scripts: the per-pair arrays
of one interface at one step, sorted by x.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import h5py
import numpy as np


def last_step_file(out: Path) -> Path | None:
    """The highest-numbered `step_NNNN.h5` in a run folder, or None if there is none.
    Step 10000 and later have five or more digits (step_10000.h5): compared by number
    (before, a 4-digit pattern returned step_9999.h5 of a longer run)."""
    files = [p for p in Path(out).glob("step_*.h5") if re.fullmatch(r"step_\d{4,}\.h5", p.name)]
    return max(files, key=lambda p: int(p.stem[5:]), default=None)


def read_pairs(path: Path, interface: int | str = 0, keys: tuple[str, ...] | None = None
               ) -> dict[str, np.ndarray]:
    """{name: (m,) or (m, k) array} of the pairs of interface `interface` in step file
    `path`, sorted by x. interface: the 0-based index of its [[interface]] in config order,
    or its name (looked up in the summary.json beside `path`). keys: the arrays to read
    (default every per-pair array). ValueError for an interface or key the file does not
    have (before, a name or a negative index read 0 pairs, and a key h5py's KeyError).
    An index that selects pairs reads the step file alone (the summary, which grows with
    every step, is parsed for a name or for an index without pairs)."""
    path = Path(path)
    index = _interface_index(path, interface)
    with h5py.File(path) as f:
        c = f["contact"]
        sel = c["interface"][()] == index
        names = keys if keys is not None else tuple(c)
        missing = sorted(set(names) - set(c))
        if missing:
            raise ValueError(f"{path}: no /contact dataset {missing}; it has {sorted(c)}")
        data = {k: c[k][()] for k in names}
    if not sel.any():  # an interface without pairs at this step, or one past them all?
        known, _ = _summary_names(path)
        if known is not None and index >= len(known):
            raise ValueError(_bad_index(interface, known))
    data = {k: v[sel] for k, v in data.items() if v.shape[:1] == sel.shape}
    order = np.argsort(data["x"]) if "x" in data else np.arange(int(sel.sum()))
    return {k: v[order] for k, v in data.items()}


def _summary_names(path: Path) -> tuple[list[str] | None, Exception | None]:
    """The interface names of the summary.json beside `path` in config order (its
    `contact_interfaces`), or None and why not."""
    try:
        return list(json.loads((path.parent / "summary.json").read_text())
                    ["contact_interfaces"]), None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        return None, exc


def _bad_index(interface: object, names: list[str] | None) -> str:
    return (f"interface {interface!r}: pass a name or the 0-based index of the [[interface]]"
            " in config order" + (f" ({len(names)} interfaces: {names})" if names else ""))


def _interface_index(path: Path, interface: int | str) -> int:
    """The 0-based index of `interface`: an index >= 0, or a name in the summary.json beside
    `path` (its `contact_interfaces` are in config order)."""
    if isinstance(interface, str):
        names, why = _summary_names(path)
        if names is None:
            raise ValueError(f"interface {interface!r}: no interface names beside {path} "
                             f"(summary.json: {why}); pass its 0-based index in config "
                             "order")
        if interface not in names:
            raise ValueError(f"interface {interface!r} is not one of {names}")
        return names.index(interface)
    if isinstance(interface, bool) or not isinstance(interface, int | np.integer) \
            or interface < 0:
        raise ValueError(_bad_index(interface, _summary_names(path)[0]))
    return int(interface)


def step_datasets(path: Path) -> dict[str, np.ndarray]:
    """Every dataset of an output HDF5 file by its path ("displacement", "contact/p"),
    read through its links: a dataset that repeats an earlier step's is an external link
    to that one copy (README, "Output"), which h5py's `visititems` does not follow."""
    out: dict[str, np.ndarray] = {}

    def walk(group: h5py.Group, prefix: str) -> None:
        for k in group:
            obj = group[k]
            if isinstance(obj, h5py.Group):
                walk(obj, f"{prefix}{k}/")
            else:
                out[prefix + k] = obj[()]

    with h5py.File(path, "r") as f:
        walk(f, "")
    return out


def standalone_copy(path: Path, dest: Path) -> None:
    """Write step file `path` to `dest` with every dataset its own real copy (no links to
    other files, no virtual datasets) and the same file attributes: a step file that reads
    on its own, without the folder's earlier step files and mesh.h5."""
    data = step_datasets(path)
    with h5py.File(path, "r") as f:
        attrs = dict(f.attrs)
    with h5py.File(dest, "w") as g:
        for k, v in attrs.items():
            g.attrs[k] = v
        for k, v in data.items():
            g[k] = v
