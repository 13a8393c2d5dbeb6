"""Field-error breakdown by bands and the floor of the ref_* L2 definition
(app/studies/field_breakdown.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.closed_form import cattaneo_traction, interpolated_l2_rel_error
from app.studies.field_breakdown import (
    band_index,
    bisect_pairs,
    edge_phase,
    field_breakdown,
    floor_sequence,
    nodal_l2,
    orders,
    sampled_floor,
    trapezoid_weights,
)
from app.studies.reference_errors import l2_against

A, P0, MU = 0.01, 549.4, 0.2


def test_trapezoid_weights_reproduce_trapz():
    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(-1.0, 2.0, 37))
    g = rng.normal(size=37)
    assert np.sum(trapezoid_weights(x) * g) == pytest.approx(np.trapz(g, x), rel=1e-13)
    assert trapezoid_weights(np.array([1.0])).tolist() == [0.0]


def test_band_index_first_band_wins():
    xr = np.array([-1.0, 0.0, 0.45, 0.5, 0.9, 2.0])
    idx = band_index(xr, [np.array([0.5]), np.array([0.4, 1.0]), np.array([])], 0.1)
    assert idx.tolist() == [3, 3, 0, 0, 1, 3]


def test_breakdown_sums_to_l2_against_and_locates_a_bump():
    xr = np.linspace(-1.5 * A, 1.5 * A, 801)
    x = np.linspace(-1.5 * A, 1.5 * A, 161)
    exact = lambda s: cattaneo_traction(s, A, P0, MU, 0.5)  # noqa: E731
    f = exact(x)
    k = int(np.argmin(np.abs(x - 0.3 * A)))
    f[k] += 0.1 * MU * P0  # a spike at one pair, as the lock-in leaves
    win = (-1.5 * A, 1.5 * A)
    bands = {"edge": np.array([-A, A]), "stick": A * np.sqrt(0.5) * np.array([-1, 1]),
             "spike": np.array([x[k]])}
    b = field_breakdown(x, f, xr, exact(xr), win, bands, half_width=A / 40)
    assert b["total"] == pytest.approx(l2_against(x, f, xr, exact(xr), win), rel=1e-12)
    assert b["total"] ** 2 == pytest.approx(sum(b[n] ** 2 for n in (*bands, "core")),
                                            rel=1e-12)
    assert b["spike"] > max(b["stick"], b["core"]) and b["edge"] > 0
    # without the spike its band holds only interpolation error, far smaller
    clean = field_breakdown(x, exact(x), xr, exact(xr), win, bands, A / 40)
    assert clean["spike"] < 0.2 * b["spike"]
    assert clean["total"] == pytest.approx(sampled_floor(x, xr, exact, win), rel=1e-12)
    assert math.isnan(field_breakdown(x, f, xr, exact(xr), (5.0, 6.0), bands, 1.0)["core"])


def test_floor_orders_sqrt_kinks_near_one_smooth_two():
    """The interpolation floor of a field with square-root edges converges at about order 1
    (unsteadily, as the edges fall differently between the pairs); a smooth field at 2."""
    xr = np.linspace(-1.5 * A, 1.5 * A, 2**12 + 1)
    win = (-1.5 * A, 1.5 * A)
    q = lambda s: cattaneo_traction(s, A, P0, MU, 0.5)  # noqa: E731
    smooth = lambda s: np.cos(2.0 * s / A)  # noqa: E731
    levels = [np.linspace(-1.5 * A, 1.5 * A, 2**k * 15 + 1) for k in range(5)]
    fq = [sampled_floor(x, xr, q, win) for x in levels]
    fs = [sampled_floor(x, xr, smooth, win) for x in levels]
    assert np.mean(orders(fq)) == pytest.approx(1.0, abs=0.3)
    assert np.allclose(orders(fs), 2.0, atol=0.1)
    assert sampled_floor(levels[0], xr, lambda s: 3.0 * s + 1.0, win) < 1e-12
    assert orders([4.0, 2.0, 0.0]) [0] == 1.0 and math.isnan(orders([4.0, 2.0, 0.0])[1])


def test_bisect_pairs_nests_the_levels():
    x = np.array([0.3, -1.0, 0.0])
    assert bisect_pairs(x, 0).tolist() == [-1.0, 0.0, 0.3]
    assert bisect_pairs(x, 1).tolist() == [-1.0, -0.5, 0.0, 0.15, 0.3]
    b2 = bisect_pairs(x, 2)
    assert b2.size == 9 and np.all(np.isin(bisect_pairs(x, 1), b2)) and np.all(np.diff(b2) > 0)


def test_floor_sequence_matches_the_direct_floors():
    q = lambda s: cattaneo_traction(s, A, P0, MU, 0.5)  # noqa: E731
    x0 = np.linspace(-1.5 * A, 1.5 * A, 16) + 0.013 * A
    seq = floor_sequence(x0, q, 1.5 * A, levels=3, ref_levels=2)
    x1, xr = bisect_pairs(x0, 1), bisect_pairs(x0, 3)
    assert [r["pairs"] for r in seq] == [16, 31, 61]
    assert seq[1]["floor_cf"] == pytest.approx(
        interpolated_l2_rel_error(x1, q(x1), q, 1.5 * A), rel=1e-12)
    inside = xr[q(xr) != 0]
    c, h = 0.5 * (inside[0] + inside[-1]), 0.5 * (inside[-1] - inside[0])
    assert seq[1]["floor_ref"] == pytest.approx(
        sampled_floor(x1, xr, q, (c - 1.5 * h, c + 1.5 * h)), rel=1e-12)
    assert seq[0]["floor_cf"] > seq[1]["floor_cf"] > seq[2]["floor_cf"] > 0


def test_nodal_l2_has_no_interpolation_floor():
    q = lambda s: cattaneo_traction(s, A, P0, MU, 0.5)  # noqa: E731
    xr = bisect_pairs(np.linspace(-1.5 * A, 1.5 * A, 16) + 0.013 * A, 3)
    x = xr[::4]  # a coarser nested level
    win = (-1.5 * A, 1.5 * A)
    assert nodal_l2(x, q(x), xr, q(xr), win) < 1e-14 < sampled_floor(x, xr, q, win)
    f = q(x) * 1.01  # 1% everywhere
    assert nodal_l2(x, f, xr, q(xr), win) == pytest.approx(0.01, rel=1e-12)
    assert math.isnan(nodal_l2(x, f, xr, q(xr), (9.0, 10.0)))


def test_edge_phase_follows_the_doubling_map_on_bisected_pairs():
    x0 = np.linspace(-1.0, 1.0, 11)  # spacing 0.2
    th = [edge_phase(bisect_pairs(x0, k), 0.13) for k in range(4)]
    assert th == pytest.approx([0.65, 0.3, 0.6, 0.2])  # frac(2 theta) each level
    assert math.isnan(edge_phase(x0, 1.5)) and math.isnan(edge_phase(x0, -1.5))
    assert edge_phase(x0, 0.0) == 0.0
