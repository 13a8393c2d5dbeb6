"""Read back the contact pairs of a written step (`step_NNNN.h5`, group `/contact`).

One reader for the study, its references and the analysis scripts: the per-pair arrays
of one interface at one step, sorted by x.
"""

from __future__ import annotations

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
