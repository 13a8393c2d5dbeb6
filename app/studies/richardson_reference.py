"""The study's Richardson-extrapolated reference (`study --reference richardson`).

Scalars (strain energy, peak pressure p_max, named-point displacements u_y) are
extrapolated per method from its finest consecutive levels (app/studies/richardson.py: observed
order from the last three levels, theoretical order 2 from the last two as the fallback
and the uncertainty). The reference method's limits replace the finest level's values in
the ref_* errors of those scalars; every method's own limit is reported too, so the
limits of different methods can be compared (they share the continuum limit).

The fields p(x), q(x) keep the finest level of the reference method as their reference
(ref_pressure_l2, ref_traction_l2): pair sets differ per level and, near the contact edges
and at irregular mesh vertices, the nodal values do not converge monotonically (README,
issue 11), so a pointwise extrapolation has no asymptotic range to rest on.
"""

from __future__ import annotations

import math

from app.studies.richardson import THEORETICAL_ORDER, richardson

REFERENCE_MODES = ("richardson", "finest")
"""`study --reference`: Richardson limits for the scalars (default; needs three
consecutive levels of the reference method, else the finest level is used) or the finest
level of the reference method for everything."""


def scalar_values(profile: dict) -> dict[str, float]:
    """The extrapolated scalars of one run: energy, p_max (contact scenes) and the named
    points' u_y."""
    out = {"energy": profile["energy"]}
    if "p_max" in profile:
        out["p_max"] = profile["p_max"]
    return out | dict(profile["points"])


def consecutive_levels(levels: list[int]) -> list[int]:
    """The longest run of consecutive levels ending at the finest one."""
    run = [max(levels)]
    while run[0] - 1 in levels:
        run.insert(0, run[0] - 1)
    return run


def method_limits(rows: list[dict], profiles: dict) -> list[dict]:
    """Per method (with at least two consecutive levels) and scalar: the Richardson result
    (app.studies.richardson.richardson) with the method, quantity, the levels used and the finest
    value; one dict per (method, quantity), the rows of richardson.csv."""
    out = []
    for m in dict.fromkeys(r["method"] for r in rows):
        levels = consecutive_levels([r["level"] for r in rows if r["method"] == m])
        if len(levels) < 2:
            continue
        seq = [scalar_values(profiles[(lv, m)]) for lv in levels]
        for q in seq[-1]:
            vals = [s.get(q, math.nan) for s in seq]
            res = richardson(vals, THEORETICAL_ORDER)
            out.append({"method": m, "quantity": q, "levels": f"{levels[0]}-{levels[-1]}",
                        "finest": vals[-1]} | res)
    return out


def reference_scalars(limits: list[dict], ref_label: str) -> dict[str, float] | None:
    """{quantity: limit} of the reference method if it was extrapolated from at least
    three levels, else None (the finest level is the reference)."""
    lims = [r for r in limits if r["method"] == ref_label]
    if not lims or lims[0]["n_levels"] < 3:
        return None
    return {r["quantity"]: r["value"] for r in lims}


def add_limit_spread(limits: list[dict], ref_label: str) -> None:
    """rel_to_reference = |limit - reference method's limit| / |reference limit|, in place."""
    ref = {r["quantity"]: r["value"] for r in limits if r["method"] == ref_label}
    for r in limits:
        v = ref.get(r["quantity"], math.nan)
        r["rel_to_reference"] = abs(r["value"] - v) / abs(v) if v else math.nan


def constructed_orders(limits: list[dict], ref_label: str) -> dict[tuple[str, str], set[int]]:
    """{(ref_label, ref_ column): levels} of the reference method's observed orders that its
    own Richardson limit fixes (they are no measurement): with Q* from levels L-2..L at the
    observed order p, the orders at levels L-1 and L both equal p; at the theoretical
    order 2 (from levels L-1, L), the order at level L equals 2. Only limits that are the
    reference (three or more levels, `reference_scalars`)."""
    out = {}
    for r in limits:
        if r["method"] != ref_label or r["n_levels"] < 3:
            continue
        last = int(str(r["levels"]).split("-")[-1])
        k = 2 if r["order_source"] == "observed" else 1
        out[(ref_label, f"ref_{r['quantity']}")] = set(range(last - k + 1, last + 1))
    return out


def unresolved_orders(rows: list[dict], limits: list[dict], ref_label: str
                      ) -> dict[tuple[str, str], set[int]]:
    """{(method, ref_ column): levels} of the observed orders log2(e_{l-1} / e_l) whose
    e_{l-1} or e_l is at most the relative uncertainty of the reference's Richardson limit
    (uncertainty_rel): the reference may account for all of such an error, so its order
    measures the reference, not the method (e.g. 1SD's energy on Hertz, below 4SD's
    limit's uncertainty at every level). Only limits that are the reference (three or
    more levels, `reference_scalars`)."""
    floors = {f"ref_{r['quantity']}": r["uncertainty_rel"] for r in limits
              if r["method"] == ref_label and r["n_levels"] >= 3}
    out: dict[tuple[str, str], set[int]] = {}
    for m in dict.fromkeys(r["method"] for r in rows):
        rr = sorted((r for r in rows if r["method"] == m), key=lambda r: r["level"])
        for col, floor in floors.items():
            levels = {cur["level"] for prev, cur in zip(rr, rr[1:], strict=False)
                      if min(prev.get(col, math.inf), cur.get(col, math.inf)) <= floor}
            if levels:
                out[(m, col)] = levels
    return out


FIELDS = ("ref_pressure_l2", "ref_pressure_l2_core", "ref_traction_l2")
"""The ref_ columns compared with the finest level of the reference method in every mode."""


def same_level_orders(rows: list[dict], ref_label: str, extrapolated: bool
                      ) -> dict[tuple[str, str], set[int]]:
    """{(method, ref_ column): levels} of the other methods' orders whose finer error is
    against the reference run at the same level (or a coarser one): a difference between
    two methods on one mesh, not an error against a finer solution, so log2(e_{l-1} / e_l)
    is no order of convergence (e.g. FEM-Q4's L2(p) "3.66" at 4SD's finest level of
    hertz.toml, levels 0-2). The fields always (they use the finest level), the scalars
    too unless `extrapolated` (Richardson limits)."""
    finest = max((r["level"] for r in rows if r["method"] == ref_label), default=None)
    if finest is None:
        return {}
    cols = [k for k in dict.fromkeys(k for r in rows for k in r) if k.startswith("ref_")
            and (k in FIELDS or not extrapolated)]
    out: dict[tuple[str, str], set[int]] = {}
    for r in rows:
        if r["method"] != ref_label and r["level"] >= finest:
            for c in cols:
                out.setdefault((r["method"], c), set()).add(r["level"])
    return out


def order_marks(rows: list[dict], limits: list[dict], ref_label: str,
                extrapolated: bool = True) -> dict[tuple[str, str], dict[int, str]]:
    """{(method, ref_ column): {level: mark}} of the orders that measure no convergence of
    the method: "*" fixed by the reference's own Richardson limit (`constructed_orders`),
    "~" an error within that limit's uncertainty (`unresolved_orders`), "=" an error
    against the reference at the same level (`same_level_orders`; extrapolated: the
    scalars' reference is a Richardson limit). Shown after the orders in the tables and
    left out of the spreads, the windows and the plots' "last order"."""
    out: dict[tuple[str, str], dict[int, str]] = {}
    for mark, found in (("=", same_level_orders(rows, ref_label, extrapolated)),
                        ("~", unresolved_orders(rows, limits, ref_label)),
                        ("*", constructed_orders(limits, ref_label))):
        for key, levels in found.items():
            out.setdefault(key, {}).update(dict.fromkeys(levels, mark))
    return out


def order_summary(rows: list[dict], last: int = 3,
                  constructed: dict[tuple[str, str], set[int]] | None = None,
                  unresolved: dict[tuple[str, str], set[int]] | None = None,
                  marks: dict[tuple[str, str], dict[int, str]] | None = None) -> list[dict]:
    """Per method and ref_ column: the observed orders (levels 1..finest), the
    min/max/spread of its `last` finest finite orders (last + 1 levels; the reference
    method's own finest level has no order), and the steadiest window: the `last`
    successive orders with the smallest spread (`window`: its levels, `window_spread`).
    constructed: {(method, column): levels} whose orders are fixed by the reference's own
    Richardson limit (`constructed_orders`): shown with a `*` and left out of the spread
    and the windows. unresolved: {(method, column): levels} whose errors are within the
    reference's uncertainty (`unresolved_orders`): shown with a `~` and left out too.
    marks: {(method, column): {level: mark}} (`order_marks`), shown and left out too."""
    cols = [k for k in dict.fromkeys(k for r in rows for k in r) if k.startswith("ref_")]
    every: dict[tuple[str, str], dict[int, str]] = {}
    for found in ({k: dict.fromkeys(v, "~") for k, v in (unresolved or {}).items()},
                  marks or {}, {k: dict.fromkeys(v, "*") for k, v in (constructed or {}).items()}):
        for key, by_level in found.items():
            every.setdefault(key, {}).update(by_level)
    out = []
    for m in dict.fromkeys(r["method"] for r in rows):
        rr = sorted((r for r in rows if r["method"] == m), key=lambda r: r["level"])
        for c in cols:
            mark = every.get((m, c), {})
            orders = [r.get(f"order_{c}", math.nan) for r in rr[1:]]
            text = [f"{o:.2f}{mark.get(r['level'], '')}" if math.isfinite(o) else "-"
                    for o, r in zip(orders, rr[1:], strict=True)]
            orders = [math.nan if r["level"] in mark else o
                      for o, r in zip(orders, rr[1:], strict=True)]
            row = {"method": m, "error": c, "orders": " ".join(text)}
            tail = [o for o in orders if math.isfinite(o)][-last:]
            if len(tail) == last:
                row |= {"min": min(tail), "max": max(tail), "spread": max(tail) - min(tail)}
            out.append(row | _steadiest_window(orders, [r["level"] for r in rr], last))
    return out


def _steadiest_window(orders: list[float], levels: list[int], last: int) -> dict:
    """{window: "l0-l1", window_spread} of the `last` successive finite orders with the
    smallest max - min; orders[k] compares levels[k] and levels[k + 1]. {} if none."""
    best: dict = {}
    for k in range(len(orders) - last + 1):
        w = orders[k : k + last]
        if all(math.isfinite(o) for o in w) and (
                not best or max(w) - min(w) < best["window_spread"]):
            best = {"window": f"{levels[k]}-{levels[k + last]}",
                    "window_spread": max(w) - min(w)}
    return best


def _g(v, fmt: str = ".6g") -> str:
    if isinstance(v, float):
        return "" if math.isnan(v) else format(v, fmt)
    return str(v)


def tables(limits: list[dict], summary: list[dict]) -> str:
    """Markdown: the Richardson limits per method and the order summary."""
    keys = ["method", "quantity", "levels", "finest", "order", "order_source", "value",
            "uncertainty_rel", "change_previous", "rel_to_reference"]
    lines = ["", "Richardson limits (order: observed from the last three levels; value: the "
             "limit; uncertainty_rel: the larger of |limit(observed order) - limit(order 2)| "
             "and change_previous = |limit - limit without the finest level|, over |limit|; "
             "rel_to_reference: |limit - reference method's limit| / |that limit|)", "",
             "| " + " | ".join(keys) + " |", "|---" * len(keys) + "|"]
    lines += ["| " + " | ".join(_g(r.get(k, math.nan)) for k in keys) + " |" for r in limits]
    keys = ["method", "error", "orders", "min", "max", "spread", "window", "window_spread"]
    lines += ["", "observed orders against the reference (levels 1..finest; *: fixed by the "
              "reference's own Richardson limit, not measured, and left out of the rest; ~: "
              "an error of the two levels is within the uncertainty of that limit, so the "
              "order is not resolved, and left out of the rest too; =: the finer error is "
              "against the reference run at its own level (a difference of two methods on "
              "one mesh), left out too; "
              "min/max/spread of the last three finite orders; window: the four successive "
              "levels whose three orders have the smallest spread, window_spread)", "",
              "| " + " | ".join(keys) + " |", "|---" * len(keys) + "|"]
    lines += ["| " + " | ".join(_g(r.get(k, math.nan), ".2f") for k in keys) + " |"
              for r in summary]
    return "\n".join(lines) + "\n"
