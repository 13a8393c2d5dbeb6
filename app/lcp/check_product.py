"""The final check's product w = M z + q for an iterate of the crash, kept for the check.

The crash (`app.lcp.crash`) ends with a product of M~ and its answer z~ (to see that no
w~_i is negative), and `lemke`'s final check then forms w = M z + q again for
z = max(zfac z~, 0) in the caller's units: two passes over M for one answer. In the round
that is expected to be the crash's last, `CheckProduct` forms the check's product itself,
in the caller's units and with the check's own expression, and hands the crash its scaled
w~; when that round ends on the answer, the check of exactly that z takes the kept w
(`w_for`) instead of a second pass. Any other z gets the check's own product.
"""

from __future__ import annotations

import numpy as np


class CheckProduct:
    """z~ -> w~ = D w / nu with w = M z + q, z = max(zfac z~, 0) (the final check's z and w).

    M (n, n), q (n,): the caller's data; D (n,) and zfac (n,): the crash's diagonal
    scaling (M~ = D M D, q~ = D q / nu, z = zfac z~ with zfac = nu D; D and nu powers of
    two, so D / nu = D^2 / zfac exactly). Only for z~ >= 0, where the clipping of the
    check changes nothing and w~ is the crash's M~ z~ + q~ (to round-off).
    """

    def __init__(self, M: np.ndarray, q: np.ndarray, D: np.ndarray, zfac: np.ndarray):
        self.M, self.q, self.zfac = M, q, zfac
        self.wscale = D * D / zfac
        self.z: np.ndarray | None = None
        self.w: np.ndarray | None = None
        self.products = 0  # passes over M made (for tests and profiles)
        self.finite = False  # some w was finite: then so is every entry of M

    def __call__(self, zt: np.ndarray) -> np.ndarray | None:
        """w~ (n,) for z~ (n,), or None when some z~_i < 0 (the caller's product then)."""
        if not (zt >= 0).all():
            return None
        z = np.maximum(zt * self.zfac, 0.0)  # the expression of the check (lemke.finish)
        with np.errstate(over="ignore", invalid="ignore"):  # (M is checked by `finite`)
            self.z, self.w = z, self.M @ z + self.q  # the expression of the check (_check)
        self.products += 1
        self.finite = self.finite or bool(np.isfinite(self.w).all())
        return self.wscale * self.w

    def w_for(self, z: np.ndarray) -> np.ndarray | None:
        """The kept w = M z + q when z is the last iterate's z to the bit, else None."""
        if self.z is None or not np.array_equal(z, self.z):
            return None
        return self.w
