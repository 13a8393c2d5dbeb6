"""Richardson extrapolation kernel (app/studies/richardson.py) on synthetic sequences with a known
limit and order, and the study's per-method limits (app/studies/richardson_reference.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.studies.reference_errors import add_orders
from app.studies.richardson import extrapolate, observed_order, richardson
from app.studies.richardson_reference import (
    consecutive_levels,
    method_limits,
    order_marks,
    order_summary,
    same_level_orders,
    unresolved_orders,
)


def seq(limit, terms, levels):
    """Q_l = limit + sum c h_l^p over (c, p) in terms, h_l = 2^-l."""
    return [limit + sum(c * 2.0 ** (-p * lv) for c, p in terms) for lv in levels]


def test_single_power_gives_exact_order_and_limit():
    q = seq(1.25, [(0.3, 1.7)], range(5))
    assert observed_order(*q[-3:]) == pytest.approx(1.7, rel=1e-10)
    assert extrapolate(q[-2], q[-1], 1.7) == pytest.approx(1.25, rel=1e-12)
    r = richardson(q)
    assert r["order_source"] == "observed" and r["order"] == pytest.approx(1.7, rel=1e-10)
    assert r["value"] == pytest.approx(1.25, rel=1e-12)
    assert r["change_previous"] == pytest.approx(0.0, abs=1e-12)  # both triples exact
    # the order-2 extrapolation differs, and that difference is the stated uncertainty
    assert r["value_theoretical"] != pytest.approx(1.25, rel=1e-6)
    assert r["uncertainty"] == pytest.approx(abs(r["value_theoretical"] - 1.25), rel=1e-9)
    assert r["uncertainty_rel"] == pytest.approx(r["uncertainty"] / 1.25)


@pytest.mark.parametrize("levels", [range(4), range(6), range(2, 8)])
def test_two_terms_uncertainty_bounds_the_error(levels):
    q = seq(-3.0, [(-2.0, 2.0), (-1.5, 3.0)], levels)  # rising to the limit, order -> 2
    r = richardson(q)
    err = abs(r["value"] + 3.0)
    assert err <= r["uncertainty"]
    assert err < abs(q[-1] + 3.0) / 5  # far better than the finest level
    assert r["order"] == pytest.approx(2.0, abs=0.6)


def test_limits_improve_with_levels():
    errs = [abs(richardson(seq(0.5, [(1.0, 2.0), (3.0, 3.0)], range(n)))["value"] - 0.5)
            for n in (3, 4, 5, 6)]
    assert all(b < a for a, b in zip(errs, errs[1:], strict=False))


def test_non_monotone_and_slow_sequences_fall_back_to_the_theoretical_order():
    q = [1.0, 1.1, 1.05]  # oscillates: no observed order
    assert math.isnan(observed_order(*q))
    r = richardson(q)
    assert r["order_source"] == "theoretical" and r["order_used"] == 2.0
    assert r["value"] == pytest.approx(1.05 + (1.05 - 1.1) / 3)
    assert r["uncertainty"] >= abs(r["value"] - 1.05)
    q = seq(2.0, [(1.0, 0.3)], range(4))  # order 0.3: outside the accepted range
    r = richardson(q)
    assert r["order"] == pytest.approx(0.3, rel=1e-9) and r["order_source"] == "theoretical"
    assert r["uncertainty"] >= abs(r["value"] - 2.0) * (1 - 1e-9)  # the far limit is inside
    r = richardson([4.0, 3.0])  # two levels: order 2 and the correction as uncertainty
    assert math.isnan(r["order"]) and r["value"] == pytest.approx(3.0 - 1 / 3)
    assert r["uncertainty"] == pytest.approx(1 / 3) and math.isnan(r["previous"])
    assert math.isnan(observed_order(1.0, 1.0, 1.0))
    with pytest.raises(ValueError):
        richardson([1.0])


def test_method_limits_and_order_summary():
    levels = [0, 1, 2, 3]
    profiles, rows = {}, []
    for m, c in (("4SD", 1.0), ("FEM-Q4", 2.0)):
        for lv, (u, p) in enumerate(zip(seq(7.0, [(c, 2.0)], levels),
                                        seq(3.0, [(-c, 1.5)], levels), strict=True)):
            profiles[(lv, m)] = {"energy": u, "p_max": p, "points": {"tip": -u}, "n_dofs": 1}
            rows.append({"level": lv, "method": m})
    lims = method_limits(rows, profiles)
    got = {(r["method"], r["quantity"]): r for r in lims}
    assert set(got) == {(m, q) for m in ("4SD", "FEM-Q4") for q in ("energy", "p_max", "tip")}
    assert got[("FEM-Q4", "energy")]["value"] == pytest.approx(7.0)
    assert got[("4SD", "tip")]["value"] == pytest.approx(-7.0)
    assert got[("4SD", "p_max")]["order"] == pytest.approx(1.5)
    assert got[("4SD", "energy")]["levels"] == "0-3" and got[("4SD", "energy")]["finest"] > 7
    assert consecutive_levels([0, 2, 3, 4]) == [2, 3, 4]
    for r in rows:
        r["ref_energy"] = 2.0 ** (-2 * r["level"])
        r["order_ref_energy"] = 2.0 if r["level"] else math.nan
    (s4,) = [s for s in order_summary(rows) if s["method"] == "4SD"]
    assert s4["orders"] == "2.00 2.00 2.00" and s4["spread"] == 0.0
    assert s4["window"] == "0-3" and s4["window_spread"] == 0.0


def test_order_summary_skips_the_reference_level_and_finds_the_steadiest_window():
    errs = [1.0, 0.5, 0.3, 0.15, 0.075, 0.0375, math.nan]  # orders 1, 0.74, 1, 1, 1, -
    rows = [{"level": lv, "method": "4SD", "ref_x": e} for lv, e in enumerate(errs)]
    for a, b in zip(rows, rows[1:], strict=False):
        b["order_ref_x"] = math.log2(a["ref_x"] / b["ref_x"]) if b["level"] < 6 else math.nan
    (s,) = order_summary(rows)
    assert s["orders"].endswith(" -") and s["spread"] == pytest.approx(0.0, abs=1e-12)
    assert s["window"] == "2-5" and s["window_spread"] == pytest.approx(0.0, abs=1e-12)
    rows[5]["order_ref_x"] = 0.2  # the finest order drops: the last window is not steady
    (s,) = order_summary(rows)
    assert s["spread"] == pytest.approx(0.8) and s["window"] == "0-3"  # first of the ties
    assert s["window_spread"] == pytest.approx(1.0 - math.log2(0.5 / 0.3))


def test_orders_within_the_reference_uncertainty_are_marked_and_left_out():
    """1SD's energy on hertz.toml (levels 0-2) is 1.6e-4, 3.6e-4, 2.1e-4 from 4SD's limit,
    whose uncertainty is 1.3e-3: its orders -1.12, 0.76 measured the reference, unmarked."""
    limits = [{"method": "4SD", "quantity": "energy", "n_levels": 4, "levels": "0-3",
               "order_source": "observed", "uncertainty_rel": 1e-3}]
    errs = {"1SD": [1.6e-4, 3.6e-4, 2.1e-4, 1.9e-4], "FEM-Q4": [4e-2, 1e-2, 2.5e-3, 8e-4]}
    rows = [{"level": lv, "method": m, "ref_energy": e}
            for m, es in errs.items() for lv, e in enumerate(es)]
    add_orders(rows)
    vague = unresolved_orders(rows, limits, "4SD")
    assert vague == {("1SD", "ref_energy"): {1, 2, 3}, ("FEM-Q4", "ref_energy"): {3}}
    got = {s["method"]: s for s in order_summary(rows, unresolved=vague)}
    assert got["1SD"]["orders"] == "-1.17~ 0.78~ 0.14~" and "spread" not in got["1SD"]
    assert got["FEM-Q4"]["orders"] == "2.00 2.00 1.64~" and "spread" not in got["FEM-Q4"]
    # without the mark, the unresolved orders entered the spread
    assert order_summary(rows)[0]["spread"] == pytest.approx(0.78 + 1.17, abs=0.01)
    # every mark together (the plots' "last order" leaves out all of them)
    limits[0]["method"] = "FEM-Q4"
    assert order_marks(rows, limits, "FEM-Q4")[("FEM-Q4", "ref_energy")] == {2: "*",
                                                                             3: "*"}


def test_the_errors_table_marks_the_same_orders(tmp_path):
    from app.studies.reference_errors import write_tables

    limits = [{"method": "4SD", "quantity": "energy", "n_levels": 3, "levels": "0-2",
               "order_source": "observed", "uncertainty_rel": 1e-3}]
    errs = {"1SD": [1.6e-4, 3.6e-4, 2.1e-4], "4SD": [4e-2, 1e-2, 2.5e-3]}
    rows = [{"level": lv, "method": m, "ref_energy": e, "n_dofs": 10, "t_total": 1.0}
            for m, es in errs.items() for lv, e in enumerate(es)]
    add_orders(rows)
    marks = order_marks(rows, limits, "4SD")
    assert marks == {("1SD", "ref_energy"): {1: "~", 2: "~"},
                     ("4SD", "ref_energy"): {1: "*", 2: "*"}}
    text = write_tables(rows, [], tmp_path, "note", marks)
    assert "| 1SD | 1 | 10 | 1.00 | 0.00036 (-1.17~) |" in text
    assert "| 4SD | 2 | 10 | 1.00 | 0.0025 (2.00*) |" in text


def test_orders_against_the_reference_at_its_own_level_are_marked():
    """hertz.toml, levels 0-2, 1SD/4SD/FEM-Q4: FEM-Q4's L2(p) against level 2 of 4SD reads
    0.0193, 0.0116, 0.00092: "3.66" at level 2 is the FEM-Q4 - 4SD difference on one mesh."""
    errs = {"4SD": [0.0192, 0.0118, math.nan], "FEM-Q4": [0.0193, 0.0116, 0.000919]}
    rows = [{"level": lv, "method": m, "ref_pressure_l2": e, "ref_energy": e}
            for m, es in errs.items() for lv, e in enumerate(es)]
    add_orders(rows)
    assert same_level_orders(rows, "4SD", extrapolated=True) == {
        ("FEM-Q4", "ref_pressure_l2"): {2}}
    assert same_level_orders(rows, "4SD", extrapolated=False) == {
        ("FEM-Q4", "ref_pressure_l2"): {2}, ("FEM-Q4", "ref_energy"): {2}}
    marks = order_marks(rows, [], "4SD")
    got = {(s["method"], s["error"]): s for s in order_summary(rows, marks=marks)}
    assert got[("FEM-Q4", "ref_pressure_l2")]["orders"] == "0.73 3.66="
    assert got[("FEM-Q4", "ref_energy")]["orders"] == "0.73 3.66"  # against a limit


def test_the_plot_rate_leaves_out_same_level_and_unresolved_errors():
    """FEM-Q4's L2(p) on hertz.toml, levels 0-2, against level 2 of 4SD: the legend's
    rate 2.24 was the fit through the same-mesh difference at level 2 (0.73 without it)."""
    from app.plotting import pyplot
    from app.studies.convergence import _error_panel

    errs = {"4SD": [0.0192, 0.0118, math.nan], "FEM-Q4": [0.0193, 0.0116, 0.000919]}
    rows = [{"level": lv, "method": m, "ref_pressure_l2": e, "n_dofs": 2532 * 4**lv}
            for m, es in errs.items() for lv, e in enumerate(es)]
    add_orders(rows)
    fig, ax = pyplot().subplots()
    _error_panel(ax, rows, ["FEM-Q4"], "ref_pressure_l2", "n_dofs", "DOFs", None,
                 order_marks(rows, [], "4SD"))
    (label,) = [t.get_text() for t in ax.get_legend().get_texts()]
    assert label == "FEM-Q4 (rate 0.73, last order 0.73)"
    fig, ax = pyplot().subplots()  # an error at most the floor is left out of the fit too
    _error_panel(ax, rows, ["FEM-Q4"], "ref_pressure_l2", "n_dofs", "DOFs",
                 {"ref_pressure_l2": 0.001}, None)
    assert ax.get_legend().get_texts()[0].get_text() == "FEM-Q4 (rate 0.73, last order 3.66)"


def test_the_reference_note_names_what_the_scene_has():
    """cantilever.toml's tables and plot titles read "Richardson limits of 4SD for energy,
    p_max and points; ... for p(x), q(x)": a scene with no contact and one point."""
    from app.studies.reference_errors import add_reference_errors

    rows = [{"level": lv, "method": "4SD"} for lv in range(3)]
    profiles = {(lv, "4SD"): {"energy": 1.0 + 4.0**-lv, "n_dofs": 4**lv,
                              "points": {"tip": -1.0 - 4.0**-lv}} for lv in range(3)}
    note = add_reference_errors(rows, profiles, "4SD", {"energy": 1.0, "tip": -1.0})
    assert note == "reference: Richardson limits of 4SD for energy, u_y(tip)"
    x = np.linspace(-1, 1, 5)
    for p in profiles.values():
        p |= {"x": x, "p": 1 - x**2, "q": 0 * x, "p_max": 1.0}
    note = add_reference_errors(rows, profiles, "4SD", {"energy": 1.0, "p_max": 1.0})
    assert note.startswith("reference: Richardson limits of 4SD for energy, p_max; level 2")


def test_the_plot_rate_is_the_levels_order_not_a_dofs_fit():
    """h halves per level, DOFs grow by less than 4 (hertz.toml 2532, 9804, 38580): an
    error at order 1.63 per level read rate 1.66 in the legend, fitted against
    DOFs^-1/2, beside the table's orders 1.63 (4SD's energy against its Richardson limit,
    `study configs/hertz.toml --levels 3 --methods 4,q4`)."""
    from app.plotting import pyplot
    from app.studies.convergence import _error_panel

    rows = [{"level": lv, "method": "4SD", "ref_energy": 0.013 * 2.0 ** (-1.63 * lv),
             "n_dofs": d} for lv, d in enumerate((2532, 9804, 38580))]
    add_orders(rows)
    fig, ax = pyplot().subplots()
    _error_panel(ax, rows, ["4SD"], "ref_energy", "n_dofs", "DOFs", None, None)
    assert ax.get_legend().get_texts()[0].get_text() == "4SD (rate 1.63, last order 1.63)"
