"""C = G_c S^-1 G_c^T formed blockwise and symmetrized in place
(app/condensation/compliance_product.py)."""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from app.condensation.compliance_product import compliance_product, symmetrize_in_place


def test_symmetrize_in_place_equals_the_mean_with_the_transpose():
    a = np.random.default_rng(0).standard_normal((23, 23))
    want = 0.5 * (a + a.T)
    got = symmetrize_in_place(a.copy(), block=5)
    assert np.allclose(got, want, rtol=0, atol=1e-15)
    assert np.array_equal(got, got.T)


def test_blockwise_product_equals_the_plain_expression():
    rng = np.random.default_rng(1)
    n_c, rows = 37, 26
    a = rng.standard_normal((n_c, n_c))
    s = a @ a.T + n_c * np.eye(n_c)
    gc = sp.random(rows, n_c, density=0.2, random_state=2, format="csr")
    fac = sla.cho_factor(s)
    plain = gc @ sla.cho_solve(fac, gc.T.toarray())
    plain = 0.5 * (plain + plain.T)
    seen = []

    def solve(b):
        seen.append(b.flags.f_contiguous)
        return sla.cho_solve(fac, b, overwrite_b=True)

    got = compliance_product(gc, solve, block=4)
    assert seen == [True]
    assert np.allclose(got, plain, rtol=1e-13, atol=1e-15 * np.abs(plain).max())
    assert np.array_equal(got, got.T)
