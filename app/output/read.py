"""Read back the contact pairs of a written step (`step_NNNN.h5`, group `/contact`).

One reader for the study, its references and the analysis scripts: the per-pair arrays
of one interface at one step, sorted by x.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np


def last_step_file(out: Path) -> Path | None:
    """The highest-numbered `step_NNNN.h5` in a run folder, or None if there is none."""
    files = sorted(Path(out).glob("step_[0-9][0-9][0-9][0-9].h5"))
    return files[-1] if files else None


def read_pairs(path: Path, interface: int = 0, keys: tuple[str, ...] | None = None
               ) -> dict[str, np.ndarray]:
    """{name: (m,) or (m, k) array} of the pairs of interface number `interface` in step
    file `path`, sorted by x. keys: the arrays to read (default every per-pair array)."""
    with h5py.File(path) as f:
        c = f["contact"]
        sel = c["interface"][()] == interface
        names = keys if keys is not None else tuple(c)
        data = {k: c[k][()] for k in names}
    data = {k: v[sel] for k, v in data.items() if v.shape[:1] == sel.shape}
    order = np.argsort(data["x"]) if "x" in data else np.arange(int(sel.sum()))
    return {k: v[order] for k, v in data.items()}
