"""Smoothness of a traction profile along an interface (verification of stripes)."""

from __future__ import annotations

import numpy as np


def local_fit_deviation(x: np.ndarray, p: np.ndarray, width: int = 5) -> np.ndarray:
    """|p_i - f_i(x_i)| / max |p| per point, f_i the least-squares quadratic through the
    `width` points around i (windows shifted inside at the ends), points sorted by x.

    x, p: (n,) positions (length) and tractions; returns (n,) in the order of the input.
    With fewer than `width` points every deviation is 0 (nothing to compare with).
    """
    x, p = np.asarray(x, float), np.asarray(p, float)
    n = x.size
    if n < width:
        return np.zeros(n)
    o = np.argsort(x)
    xs, ps = x[o], p[o]
    start = np.clip(np.arange(n) - width // 2, 0, n - width)
    idx = start[:, None] + np.arange(width)  # (n, width)
    xc = xs[idx] - xs[:, None]  # centred on the point itself: the fit value is c0
    a = np.stack([np.ones_like(xc), xc, xc * xc], axis=-1)  # (n, width, 3)
    coef = np.einsum("nkw,nw->nk", np.linalg.pinv(a), ps[idx])
    dev = np.empty(n)
    dev[o] = np.abs(ps - coef[:, 0]) / max(np.abs(p).max(), 1e-300)
    return dev
