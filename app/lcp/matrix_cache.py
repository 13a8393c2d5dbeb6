"""What `lemke` derives from the matrix M alone, kept between solves that share M.

The contact LCP's M is built once per run; the load steps and the debonding rounds of a
step change only q (`app.interface.coulomb`). Every solve of `lemke` still read M whole
several times for results that depend on M only: its finiteness (the column probe), the
symmetric scaling (D, mu), the twins of the warm crash and the largest entry of the
scaled M in the final check's floor, and it factorized the warm-start basis's block afresh
(twice: to try it, and for the crash's block pivoting from it). A `MatrixCache` bound to M
keeps those results, and the crash's block solver (`app.lcp.crash`): its factors of a
basis block and the bordered rows and columns of the indices that changed since depend
on M alone, so the next solve's warm-start basis, a few indices away, is solved on them
without a new factorization.

The M-only results are the same bits as without the cache. The solves on the kept block
solver are the same to round-off (a bordered solve with one residual correction, not a
fresh LU), and every answer still passes `lemke`'s final check. The cache serves only the
very array it was made for (`for_matrix`; a balanced or transformed copy gets none), and
that array is made read-only: a change of M, which would leave the entries stale, raises
instead.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Hashable
from typing import Any

import numpy as np


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
        self.hits: Counter[str] = Counter()
        self.misses: Counter[str] = Counter()

    def get(self, key: Hashable, compute: Callable[[], Any], keep: int | None = None) -> Any:
        """The entry `key` (a tuple whose first item names its kind), computed once.
        keep: at most this many entries of the kind are kept, the most recently used
        (for kinds keyed on data that can take many values over a run)."""
        kind = key[0] if isinstance(key, tuple) else str(key)
        if key in self._memo:
            self.hits[kind] += 1
            if keep is not None:  # most recently used last
                self._memo[key] = self._memo.pop(key)
            return self._memo[key]
        self.misses[kind] += 1
        value = self._memo[key] = compute()
        if keep is not None:
            mine = [k for k in self._memo if isinstance(k, tuple) and k[0] == kind]
            for k in mine[:-keep]:
                del self._memo[k]
        return value


def for_matrix(cache: MatrixCache | None, M: np.ndarray) -> MatrixCache | None:
    """The cache when it was made for this very array M, else None."""
    return cache if cache is not None and cache.M is M else None
