"""The reference method's orders that its own Richardson limit fixes are marked and left
out of the order summary's spread and windows (app/studies/richardson_reference.constructed_orders).

With Q* extrapolated from levels L-2..L at their observed order p, the reference's errors
|Q_l - Q*| have the order p at levels L-1 and L whatever the data: a spread computed with
them claimed a steadiness that two of its three orders did not measure (e.g. 4SD's energy
on hertz_halfspace, "1.86 1.93 2.26 2.26": spread 0.33 over levels 1-4)."""

from __future__ import annotations

import math

import pytest

from app.studies.reference_errors import add_reference_errors
from app.studies.richardson_reference import (
    constructed_orders,
    method_limits,
    order_summary,
    reference_scalars,
    tables,
)


def _study(energies: list[float]) -> tuple[list[dict], list[dict]]:
    """Rows with ref_energy against the Richardson limit of 4SD (the only method)."""
    rows, profiles = [], {}
    for lv, u in enumerate(energies):
        profiles[(lv, "4SD")] = {"energy": u, "points": {}, "n_dofs": 4**lv}
        rows.append({"level": lv, "method": "4SD"})
    lims = method_limits(rows, profiles)
    add_reference_errors(rows, profiles, "4SD", reference_scalars(lims, "4SD"))
    return rows, lims


def test_observed_order_fixes_the_last_two_orders():
    h = [2.0**-lv for lv in range(5)]
    rows, lims = _study([1.0 + x**2 + 3 * x**3 for x in h])  # orders drift towards 2
    (lim,) = lims
    assert lim["order_source"] == "observed"
    fixed = constructed_orders(lims, "4SD")
    assert fixed == {("4SD", "ref_energy"): {3, 4}}
    for r in rows[3:]:  # what makes them no measurement
        assert r["order_ref_energy"] == pytest.approx(lim["order"], rel=1e-9)
    (s,) = order_summary(rows, constructed=fixed)
    assert s["orders"].split()[2:] == [f"{lim['order']:.2f}*"] * 2
    assert "spread" not in s and "window" not in s  # two measured orders only
    (old,) = order_summary(rows)  # without the marks: a spread of two fixed orders
    assert old["spread"] < 0.4
    assert "*: fixed by the reference's own Richardson limit" in tables(lims, [s])


def test_theoretical_order_fixes_the_last_order_only():
    rows, lims = _study([1.0, 1.5, 1.2, 1.1, 1.09, 1.08])  # order 0: order 2 is used
    (lim,) = lims
    assert lim["order_source"] == "theoretical"
    fixed = constructed_orders(lims, "4SD")
    assert fixed == {("4SD", "ref_energy"): {5}}
    assert rows[5]["order_ref_energy"] == pytest.approx(2.0)
    (s,) = order_summary(rows, constructed=fixed)
    assert s["orders"].endswith("2.00*")
    orders = [r["order_ref_energy"] for r in rows[2:5]]
    assert s["spread"] == pytest.approx(max(orders) - min(orders))


def test_other_methods_and_short_references_are_not_marked():
    lims = [{"method": "FEM-Q4", "quantity": "energy", "levels": "0-3", "n_levels": 4,
             "order_source": "observed"},
            {"method": "4SD", "quantity": "p_max", "levels": "0-1", "n_levels": 2,
             "order_source": "theoretical"}]
    assert constructed_orders(lims, "4SD") == {}
    rows = [{"level": lv, "method": "4SD", "ref_x": 2.0**-lv,
             "order_ref_x": 1.0 if lv else math.nan} for lv in range(4)]
    (s,) = order_summary(rows, constructed={})
    assert s["orders"] == "1.00 1.00 1.00" and s["spread"] == 0.0


def test_the_plot_legend_gives_the_last_measured_order():
    from app.plotting import pyplot
    from app.studies.convergence import _error_panel

    h = [2.0**-lv for lv in range(5)]
    rows, lims = _study([1.0 + x**2 + 3 * x**3 for x in h])
    for r in rows:
        r["n_dofs"] = 4.0**r["level"]
    fig, ax = pyplot().subplots()
    _error_panel(ax, rows, ["4SD"], "ref_energy", "n_dofs", "DOFs", None,
                 constructed_orders(lims, "4SD"))
    (label,) = [t.get_text() for t in ax.get_legend().get_texts()]
    assert label.endswith(f"last order {rows[2]['order_ref_energy']:.2f})")
