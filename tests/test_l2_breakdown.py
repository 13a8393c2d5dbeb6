"""The Hertz L2(p) breakdown (app/studies/l2_breakdown.py): tributary averages, core and edge
parts, the worst pair."""

from __future__ import annotations

import numpy as np
import pytest

from app.closed_form import hertz_pressure, interpolated_l2_rel_error
from app.studies.l2_breakdown import (
    hertz_form_fit,
    hertz_tributary_average,
    interpolated_l2_best,
    pressure_breakdown,
    tributary_bounds,
)

A, P0 = 0.01, 549.4


def pairs(n: int, span: float = 1.5):
    x = np.linspace(-span * A, span * A, n)
    b = tributary_bounds(x)
    return x, b[1:] - b[:-1]


def test_tributary_average_conserves_the_force_and_tends_to_point_values():
    x, w = pairs(61)
    avg = hertz_tributary_average(x, A, P0)
    assert np.sum(avg * w) == pytest.approx(np.pi * A * P0 / 2, rel=1e-12)  # Hertz force
    xf, _ = pairs(6001)
    inner = np.abs(xf) < 0.5 * A
    assert np.allclose(hertz_tributary_average(xf, A, P0)[inner],
                       hertz_pressure(xf, A, P0)[inner], rtol=1e-6)
    assert np.all(hertz_tributary_average(x, A, P0) >= 0)


def test_breakdown_of_exact_and_averaged_profiles():
    x, w = pairs(47)
    exact = pressure_breakdown(x, hertz_pressure(x, A, P0), w, A, P0)
    assert exact["l2"] == 0 and exact["average_floor"] > 0 and exact["loaded_outside"] == 0
    wider = hertz_pressure(x, 1.1 * A, P0)  # loaded up to 1.1 a: pairs outside |x| < a
    assert pressure_breakdown(x, wider, w, A, P0)["loaded_outside"] == int(
        np.sum((np.abs(x) >= A) & (np.abs(x) < 1.1 * A)))
    avg = hertz_tributary_average(x, A, P0)
    b = pressure_breakdown(x[::-1], avg[::-1], w[::-1], A, P0)  # any order
    assert b["l2"] == pytest.approx(b["average_floor"], rel=1e-12)
    assert b["l2"] ** 2 == pytest.approx(b["l2_core"] ** 2 + b["l2_edge"] ** 2, rel=1e-12)
    assert b["l2_edge"] > b["l2_core"]  # averaging a sqrt profile costs most at the edges
    assert abs(b["worst_x_over_a"]) > 0.9 and b["worst_error_over_p0"] < 0
    # a bump at one core pair is found as the worst pair and lands in the core part
    p = hertz_pressure(x, A, P0)
    k = int(np.argmin(np.abs(x - 0.3 * A)))
    p[k] += 0.01 * P0
    b = pressure_breakdown(x, p, w, A, P0)
    assert b["worst_x_over_a"] == pytest.approx(x[k] / A)
    assert b["worst_error_over_p0"] == pytest.approx(0.01)
    assert b["l2_edge"] == 0 and b["l2_core"] == b["l2"] > 0
    assert exact["odd_even_over_p0"] == 0
    x, w = pairs(301)
    smooth = hertz_pressure(x, A, P0) + 0.002 * P0 * np.cos(3 * x / A)
    assert pressure_breakdown(x, smooth, w, A, P0)["odd_even_over_p0"] < 1e-5
    alternating = hertz_pressure(x, A, P0) + 0.0005 * P0 * (-1.0) ** np.arange(x.size)
    b = pressure_breakdown(x, alternating, w, A, P0)
    assert b["odd_even_over_p0"] == pytest.approx(0.0005, rel=0.05)


def hertz(t):
    return hertz_pressure(t, A, P0)


def test_best_pair_values_reproduce_what_the_interpolant_can_hold():
    """A non-negative function linear between the pairs (constant beyond them) is fitted
    exactly; a negative one gives zeros (error 100%): the bound is active."""
    rng = np.random.default_rng(1)
    x = np.sort(rng.uniform(-1.4 * A, 1.4 * A, 25))
    v = rng.uniform(0.0, P0, x.size)
    err, best = interpolated_l2_best(x[::-1], lambda t: np.interp(t, x, v), 1.5 * A)
    assert err < 1e-9
    np.testing.assert_allclose(best[::-1], v, rtol=1e-6, atol=1e-6 * P0)
    err, best = interpolated_l2_best(x, lambda t: -np.ones_like(t), 1.5 * A)
    assert err == pytest.approx(1.0) and np.all(np.abs(best) < 1e-8)


def test_best_pair_values_bound_the_floor_and_any_other_values():
    """No values do better: not the exact pressure sampled at the pairs (the floor), not
    random perturbations of the best ones, and the best error falls with the spacing."""
    rng = np.random.default_rng(2)
    errors = []
    for n in (21, 41, 81):
        x = np.linspace(-1.5 * A, 1.5 * A, n) + rng.uniform(-0.2, 0.2, n) * 3 * A / n
        err, best = interpolated_l2_best(x, hertz, 1.5 * A)
        assert err < interpolated_l2_rel_error(x, hertz(x), hertz, 1.5 * A)
        assert err == pytest.approx(interpolated_l2_rel_error(x, best, hertz, 1.5 * A))
        for _ in range(5):
            other = np.clip(best + rng.normal(0.0, 0.002 * P0, n), 0.0, None)
            assert interpolated_l2_rel_error(x, other, hertz, 1.5 * A) >= err
        errors.append(err)
    assert errors[0] > errors[1] > errors[2]


def test_hertz_form_fit_finds_a_narrower_more_peaked_profile():
    x = np.linspace(-1.2 * A, 1.2 * A, 801)
    p = 1.002 * P0 * np.sqrt(np.clip(1 - (x / (0.995 * A)) ** 2, 0.0, None))
    peak, half = hertz_form_fit(x, p, A, P0)
    assert peak == pytest.approx(0.002, abs=1e-8) and half == pytest.approx(-0.005, abs=1e-8)
