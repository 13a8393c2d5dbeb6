"""The block matrix of the modified Coulomb LCP (app/lcp/coulomb_matrix.py): the
tangential stiffness H = C_tt^-1 under material contrast and with a true null space, and
the contact LCP (app/interface/coulomb.py) solved with it. Plain numpy, no mesh.

The compliances come from a small elastic model: three bodies A, B, C with stiffness
E_b (A_b A_b^T / n + I / 2) each, interface 1 between A and B, interface 2 between B and
C (B is shared, so the interfaces are coupled), C = G K^-1 G^T."""

import numpy as np
import pytest

from app.interface.coulomb import ContactLCP, _symmetric_scaling
from app.lcp.coulomb_matrix import NULL_STIFFNESS_REL, tangential_stiffness

K_PAIRS = 3  # pairs per interface


def _model(stiff: float, extra_rows: bool = False, seed: int = 0) -> tuple[np.ndarray, int]:
    """(C (2m, 2m), m): A and B of stiffness `stiff`, C of 1, K_PAIRS pairs per interface
    (normal rows first). extra_rows: two more pairs, a copy of interface 1's first pair
    (equal rows: the same G row) and a pair that touches no free DOF (a zero row)."""
    rng = np.random.default_rng(seed)
    nb = 2 * K_PAIRS + 2

    def body(n: int, e: float) -> np.ndarray:
        a = rng.standard_normal((n, n))
        return e * (a @ a.T / n + 0.5 * np.eye(n))

    blocks = [body(nb, stiff), body(2 * nb, stiff), body(nb, 1.0)]
    off = np.cumsum([0] + [b.shape[0] for b in blocks])
    K = np.zeros((off[-1], off[-1]))
    for i, b in enumerate(blocks):
        K[off[i]:off[i + 1], off[i]:off[i + 1]] = b
    m = 2 * K_PAIRS + (2 if extra_rows else 0)
    gn, gt = np.zeros((m, off[-1])), np.zeros((m, off[-1]))
    for i in range(K_PAIRS):
        for g, d in ((gn, 0), (gt, 1)):
            g[i, off[0] + 2 * i + d], g[i, off[1] + 2 * i + d] = -1.0, 1.0  # A-B
            g[K_PAIRS + i, off[1] + nb + 2 * i + d] = -1.0  # B-C
            g[K_PAIRS + i, off[2] + 2 * i + d] = 1.0
    if extra_rows:
        gn[2 * K_PAIRS], gt[2 * K_PAIRS] = gn[0], gt[0]  # row m-1 stays zero
    g = np.vstack([gn, gt])
    c = g @ np.linalg.solve(K, g.T)
    return 0.5 * (c + c.T), m


@pytest.mark.parametrize("stiff", [1e11, 1e12])
def test_tangential_stiffness_under_contrast_with_a_true_null_space(stiff):
    """C_tt of two interfaces 1e11 / 1e12 apart in compliance, sharing a body, plus equal
    rows and a zero row. The stiff interface's compliance eigenvalues are ~1/stiff of the
    largest: unscaled, they were taken for the null space (below 1e-10 of the largest) and
    given the null-space tie; q = H tau was 95% (1e11) to 100% (1e12) off there. H must
    invert C_tt on its range (every pair against its own scale) and count exactly the
    two dependent directions (before: 5, and q 100% off on the stiff pairs)."""
    c, m = _model(stiff, extra_rows=True)
    ctt = c[m:, m:]
    h, dependent = tangential_stiffness(ctt)
    assert dependent == 2
    np.testing.assert_allclose(h, h.T, rtol=0, atol=1e-14 * np.abs(h).max())
    rng = np.random.default_rng(1)
    q0 = rng.uniform(0.5, 1.5, m) * rng.choice([-1.0, 1.0], m)
    q0[-1] = 0.0  # the zero row's force moves nothing
    q = h @ (ctt @ q0)
    # the force of every pair outside the null space is unique: q0 (stiff and soft;
    # measured 4e-11 and 2e-10 at 1e11 and 1e12)
    unique = np.r_[1:2 * K_PAIRS]
    np.testing.assert_allclose(q[unique], q0[unique], rtol=1e-8)
    # the two equal rows share their force (only the sum is unique; 1.5e-7: H holds the
    # tie, 1e9 times their stiffness, on their rows, and its round-off; 1.5e-8 without
    # contrast before), the zero row gets 0
    assert q[0] + q[2 * K_PAIRS] == pytest.approx(q0[0] + q0[2 * K_PAIRS], rel=1e-6)
    assert abs(q[-1]) < 1e-12 * np.abs(q0).max()
    # the null directions carry a stiff tie, against their own pairs' compliance
    n = np.zeros(m)
    n[0], n[2 * K_PAIRS] = 1.0, -1.0
    assert n @ h @ n > 1e-2 * NULL_STIFFNESS_REL / ctt[0, 0]
    assert h[-1, -1] > 1e-2 * NULL_STIFFNESS_REL / ctt.diagonal()[:-1].max()


@pytest.mark.parametrize("stiff", [1e10, 1e11, 1e12])
def test_stick_forces_of_a_stiff_interface_next_to_a_soft_one(stiff):
    """Both interfaces pressed and held in stick (mu = 100): p and q solve C [p; q] =
    -[gap_free; tau_free]. Before, q on the stiff interface was 95% (1e11) and 100% (1e12)
    off, p 5%; 1e10 passed by the Cholesky check alone."""
    c, m = _model(stiff)
    size = np.r_[np.full(K_PAIRS, 1.0 / stiff), np.ones(K_PAIRS)]  # each interface's motion
    gap_free = -1e-3 * size * np.array([1.0, 2.0, 1.5, 1.0, 1.2, 0.8])
    tau_free = 1e-4 * size * np.array([1.0, -2.0, 0.5, 1.0, -1.0, 0.3])
    mu = np.full(m, 100.0)
    lcp = ContactLCP(c, mu, np.ones(m, dtype=bool))
    sol = lcp.solve(gap_free, tau_free, np.zeros(m), np.zeros(m), np.zeros(m), mu,
                    np.zeros(0))
    assert sol.status == "solved" and lcp.dependent_tangential == 0
    ref = np.linalg.solve(c, -np.r_[gap_free, tau_free])
    np.testing.assert_allclose(sol.p, ref[:m], rtol=1e-9)
    np.testing.assert_allclose(sol.q, ref[m:], rtol=1e-9)


def test_lcp_scaling_judges_a_diagonal_in_its_own_units():
    """The p column of a pair of compliance 1e-15 also holds mu (0.3, in its slip row,
    whose diagonal is the stiffness 1/c_t = 1e15): its diagonal is a genuine compliance and
    scales it (before: below 1e-12 x mu, so mu scaled it, and on a floating scene the
    stiff interface's forces were 11% off). A diagonal that is round-off of its column's
    couplings (1e-30 beside compliances 1e-3) is not used."""
    big = np.array([[2e-15, 0.0, 0.0],
                    [0.3, 1e15, 0.0],
                    [0.0, 0.0, 1.0]])
    d = _symmetric_scaling(big)
    np.testing.assert_allclose((d * d) * big.diagonal(), 1.0, rtol=1e-12)
    soft = np.array([[1e-3, 5e-4], [5e-4, 1e-30]])
    d = _symmetric_scaling(soft)
    assert d[1] ** 2 == pytest.approx(1.0 / 5e-4)  # the column's largest entry


def test_lcp_scaling_ignores_a_round_off_row_in_another_columns_reach():
    """A floating mode that slides no pair has a round-off diagonal (Z ~ 1e-35) beside its
    coupling V to a pair's p (0.5): that row is itself round-off, so it must not make the p
    column's diagonal (a compliance 1e-3) look like round-off of its couplings (before:
    the p column fell back to its largest entry 0.5, 500x its diagonal, and Lemke pivoted
    where the scaled start was the answer). The mode's own column still uses its largest
    entry, and the contrast case (a genuine 2e-15 diagonal beside mu) keeps its own."""
    big = np.array([[1e-3, 2e-4, 0.5],
                    [2e-4, 2e-3, 0.3],
                    [-0.5, -0.3, 1e-35]])
    d = _symmetric_scaling(big)
    np.testing.assert_allclose((d * d)[:2] * big.diagonal()[:2], 1.0, rtol=1e-12)
    assert d[2] ** 2 == pytest.approx(1.0 / 0.5)
    contrast = np.array([[2e-15, 0.0, 0.4],
                         [0.3, 1e15, 0.0],
                         [-0.4, 0.0, 1e-35]])
    d = _symmetric_scaling(contrast)
    np.testing.assert_allclose((d * d)[:2] * contrast.diagonal()[:2], 1.0, rtol=1e-12)
    assert d[2] ** 2 == pytest.approx(1.0 / 0.4)


def test_stick_forces_of_equal_rows_sum_to_round_off():
    """Two equal pairs (interface 1's first pair and its copy) and a zero pair, all held
    in stick (mu = 100): only the sums of the equal pairs' p and q are unique, and they
    must solve C [p; q] = -[gap_free; tau_free] like any force. The stiff tie on the null
    space (k0 = 1e9 x the stiffness) summed into H carried round-off eps x k0 into the
    sum: q's was 1.9e-7 off the least-squares answer and the motion residual 1.3e-8 of
    the free motion; with the tie kept apart (`CoulombMatrix.apply_h`) 3.7e-10 and 2.3e-11."""
    c, m = _model(1.0, extra_rows=True)
    gap_free = -1e-3 * np.array([1.0, 2.0, 1.5, 1.0, 1.2, 0.8, 1.0, 0.0])
    tau_free = 1e-4 * np.array([1.0, -2.0, 0.5, 1.0, -1.0, 0.3, 1.0, 0.0])
    mu = np.full(m, 100.0)
    lcp = ContactLCP(c.copy(), mu, np.ones(m, dtype=bool))
    sol = lcp.solve(gap_free, tau_free, np.zeros(m), np.zeros(m), np.zeros(m), mu,
                    np.zeros(0))
    assert sol.status == "solved" and lcp.dependent_tangential == 2
    rhs = np.r_[gap_free, tau_free]
    ref = np.linalg.lstsq(c, -rhs, rcond=1e-13)[0]
    a, b = 0, 2 * K_PAIRS
    assert sol.q[a] + sol.q[b] == pytest.approx(ref[m + a] + ref[m + b], rel=1e-8)
    assert sol.p[a] + sol.p[b] == pytest.approx(ref[a] + ref[b], rel=1e-9)
    assert np.abs(c @ np.r_[sol.p, sol.q] + rhs).max() < 1e-9 * np.abs(rhs).max()
