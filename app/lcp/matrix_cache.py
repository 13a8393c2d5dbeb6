"""What `lemke` derives from the matrix M alone, kept between solves that share M.

The contact LCP's M is built once per run; the load steps and the debonding rounds of a
step change only q (`app.interface.coulomb`). Every solve of `lemke` still read M whole
several times for results that depend on M only: its finiteness (the column probe), the
symmetric scaling (D, mu), the twins of the warm crash and the largest entry of the
scaled M in the final check's floor. A `MatrixCache` bound to M keeps those, and the LU
factors of the basis blocks the final solve factorized last (`lu`), so that a solve costs
its own pivots and one check.

Every entry is a pure function of M (and its key), computed by the code that computed it
before: a solve with the cache returns the same bits as one without. The cache serves only
the very array it was made for (`for_matrix`; a balanced or transformed copy gets none),
and that array is made read-only: a change of M, which would leave the entries stale,
raises instead.
"""

from __future__ import annotations

from collections import Counter, OrderedDict
from collections.abc import Callable, Hashable
from typing import Any

import numpy as np

LU_KEEP = 2
"""LU factors of basis blocks kept (the newest first): the basis a solve ended on is the
next solve's warm start."""


class MatrixCache:
    """Results that depend on one LCP matrix M (n, n) alone; see the module docstring.

    M must be a float array that owns its data (a view could change through its base);
    it is made read-only. `hits` and `misses` count the lookups per kind of entry (for
    tests and profiles)."""

    def __init__(self, M: np.ndarray):
        if not isinstance(M, np.ndarray) or M.dtype != np.float64 or M.ndim != 2 \
                or not M.flags.owndata:
            raise ValueError("MatrixCache needs a 2-D float64 array that owns its data")
        M.flags.writeable = False
        self.M = M
        self._memo: dict[Hashable, Any] = {}
        self._lus: OrderedDict[Hashable, Any] = OrderedDict()
        self.hits: Counter[str] = Counter()
        self.misses: Counter[str] = Counter()

    def get(self, key: Hashable, compute: Callable[[], Any]) -> Any:
        """The entry `key` (a tuple whose first item names its kind), computed once."""
        kind = key[0] if isinstance(key, tuple) else str(key)
        if key in self._memo:
            self.hits[kind] += 1
            return self._memo[key]
        self.misses[kind] += 1
        value = self._memo[key] = compute()
        return value

    def lu(self, key: Hashable, compute: Callable[[], Any]) -> Any:
        """LU factors of a basis block (key: the block's scaling and index set), computed
        once while among the LU_KEEP newest."""
        if key in self._lus:
            self.hits["lu"] += 1
            self._lus.move_to_end(key)
            return self._lus[key]
        self.misses["lu"] += 1
        value = self._lus[key] = compute()
        while len(self._lus) > LU_KEEP:
            self._lus.popitem(last=False)
        return value


def for_matrix(cache: MatrixCache | None, M: np.ndarray) -> MatrixCache | None:
    """The cache when it was made for this very array M, else None."""
    return cache if cache is not None and cache.M is M else None
