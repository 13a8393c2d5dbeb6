"""Study figures that need no closed form: errors against a reference of the same model,
observed orders of convergence and the CS-FEM energy bracket.

Reference: the finest level of one method (default 4SD); with scalars given (study
--reference richardson, app/studies/richardson_reference.py) the Richardson limits of its energy,
peak pressure and point displacements replace its finest values. Its pair pressures p(x) and
tractions q(x) (last step, first interface), strain energy, peak pressure and named-point
displacement are compared with every other run:
  ref_energy      |U - U_ref| / |U_ref|
  ref_p_max       |max p - max p_ref| / max p_ref
  ref_pressure_l2 ||p_h - p_ref|| / ||p_ref||, along the reference's contact direction t
                  (its loaded pairs' mean tangent, x on an untilted scene; none when the
                  contact is not near-straight), p_h interpolated linearly between its pairs
                  onto the reference pairs within 1.5 x the reference contact half-width of
                  the contact centre (trapezoidal rule); ref_traction_l2 the same for q;
                  ref_pressure_l2_core the same within 0.8 x the half-width (without the
                  contact edges, where the error depends on where the edge falls between
                  the pairs and converges unsteadily)
  ref_tip         |u_y - u_y,ref| / |u_y,ref| at the [reference] point (timoshenko)
Observed order between levels l-1 and l (h halves): log2(e_{l-1} / e_l), column order_<e>.
Energy bracket per level: U(1SD) and U(FEM-Q4), or U(16SD) if FEM-Q4 was not run; with
loads prescribed U(1SD) is the upper bound, with displacements prescribed the lower.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from app.output.read import read_pairs
from app.output.xdmf import atomic_write_bytes
from app.plotting import pyplot
from app.references.hertz import STRAIGHT_SINE, line_direction

WINDOW = 1.5  # L2 window, in reference contact half-widths around the contact centre
CORE = 0.8  # ref_pressure_l2_core: the window without the contact edges (same units)


def profile(summary: dict, run_out: Path) -> dict:
    """What the reference comparison needs from one run (rank 0): energy, peak pressure,
    point displacements and the last step's pairs of interface 0: positions X (m, 2), p,
    q, and the contact's own direction t (2,) with the largest sine of a loaded pair's
    tangent against it (`app.references.hertz.line_direction`)."""
    out = {"energy": summary["strain_energy"], "n_dofs": summary["n_dofs"],
           "points": {k: v["uy"] for k, v in summary.get("point_values", {}).items()}}
    steps = summary.get("steps") or []
    path = Path(run_out) / f"step_{len(steps):04d}.h5"
    if steps and "max_contact_pressure" in steps[-1] and path.is_file():
        pairs = read_pairs(path, 0, ("x", "y", "p", "q", "tangent", "length"))
        out |= {"X": np.column_stack((pairs["x"], pairs["y"])), "p": pairs["p"],
                "q": pairs["q"], "p_max": float(pairs["p"].max(initial=0.0))}
        if pairs["p"].size:
            out["t"], out["turn"] = line_direction(pairs["tangent"], pairs["length"],
                                                   pairs["p"])
    return out


def _with_positions(pr: dict) -> dict:
    """pr with positions X and a direction t: a profile given along x only (x, p, q) lies
    on y = 0 along t = (1, 0)."""
    if "X" in pr or "x" not in pr:
        return pr
    x = np.asarray(pr["x"], dtype=float)
    return pr | {"X": np.column_stack((x, np.zeros_like(x))), "t": np.array([1.0, 0.0]),
                 "turn": 0.0}


def along(pr: dict, t: np.ndarray) -> dict:
    """pr's pairs along direction t (the reference's): x = X.t (x itself on an untilted
    scene, t = (1, 0)), with p and q, sorted by it."""
    x = pr["X"] @ t
    o = np.argsort(x, kind="stable")
    return {"x": x[o], "p": pr["p"][o], "q": pr["q"][o]}


def l2_against(x: np.ndarray, f: np.ndarray, xr: np.ndarray, fr: np.ndarray,
               window: tuple[float, float], norm: np.ndarray | None = None) -> float:
    """||f_h - f_ref|| / ||norm|| over window, f_h interpolated at the reference points xr
    (sorted); norm defaults to f_ref."""
    sel = (xr >= window[0]) & (xr <= window[1])
    xs = xr[sel]
    if xs.size < 2 or x.size < 2:
        return math.nan
    fh = np.interp(xs, x, f)
    den = np.trapz((fr[sel] if norm is None else norm[sel]) ** 2, xs)
    return float(np.sqrt(np.trapz((fh - fr[sel]) ** 2, xs) / den)) if den > 0 else math.nan


def contact_window(x: np.ndarray, p: np.ndarray, factor: float = WINDOW
                   ) -> tuple[float, float]:
    """(lo, hi): factor x the half-width of the zone where p > 0, around its centre."""
    inside = x[p > 0]
    if inside.size == 0:
        return (math.nan, math.nan)
    c, half = 0.5 * (inside.min() + inside.max()), 0.5 * (inside.max() - inside.min())
    return (c - factor * half, c + factor * half)


def add_reference_errors(rows: list[dict], profiles: dict, ref_label: str,
                         scalars: dict | None = None) -> str:
    """Add ref_* and order_* columns to rows in place; returns a note naming the reference.

    scalars: {"energy": U*, "p_max": p*, <point>: u*} (e.g. Richardson limits,
    app/studies/richardson_reference.py) replace the finest level's values for those errors; the
    fields p(x), q(x) are always compared with the finest level of ref_label."""
    levels = [r["level"] for r in rows if r["method"] == ref_label]
    if not levels:
        return "no reference (the reference method has no completed run)"
    profiles = {k: _with_positions(v) for k, v in profiles.items()}
    ref = dict(profiles[(max(levels), ref_label)])
    note = f"reference: level {max(levels)} of {ref_label} ({ref['n_dofs']} DOFs)"
    if scalars:
        ref |= {k: scalars[k] for k in ("energy", "p_max") if k in scalars}
        ref["points"] = {k: scalars.get(k, v) for k, v in ref["points"].items()}
        names = [k for k in ("energy", "p_max") if k in scalars] + [
            f"u_y({k})" for k in ref["points"] if k in scalars]  # what this scene has
        note = (f"reference: Richardson limits of {ref_label} for {', '.join(names)}" + (
            f"; level {max(levels)} of {ref_label} ({ref['n_dofs']} DOFs) for p(x), q(x)"
            if "X" in ref else ""))
    fields_ok = "t" in ref and ref["turn"] <= STRAIGHT_SINE
    if "t" in ref and not fields_ok:
        note += (f"; no p(x), q(x) errors: the contact is not near-straight (a loaded "
                 f"pair's tangent {np.degrees(np.arcsin(min(ref['turn'], 1.0))):.3g} deg "
                 "from the mean)")
    if fields_ok:  # p and q along the reference's contact direction, in every run
        ref |= along(ref, ref["t"])
    win = contact_window(ref["x"], ref["p"]) if fields_ok else None
    core = contact_window(ref["x"], ref["p"], CORE) if fields_ok else None
    has_q = "q" in ref and np.abs(ref["q"]).max(initial=0.0) > 1e-12 * ref.get("p_max", 1)
    for r in rows:
        pr = profiles[(r["level"], r["method"])]
        is_ref = r["level"] == max(levels) and r["method"] == ref_label
        vals = {"ref_energy": relative_error(pr["energy"], ref["energy"])}
        if "X" in ref and "X" in pr:
            vals["ref_p_max"] = relative_error(pr["p_max"], ref["p_max"])
        if win is not None and "X" in pr:
            pr = pr | along(pr, ref["t"])
            vals["ref_pressure_l2"] = l2_against(pr["x"], pr["p"], ref["x"], ref["p"], win)
            vals["ref_pressure_l2_core"] = l2_against(pr["x"], pr["p"], ref["x"], ref["p"],
                                                      core)
            if has_q:
                vals["ref_traction_l2"] = l2_against(pr["x"], pr["q"], ref["x"], ref["q"], win)
        for name, uy in ref["points"].items():
            if name in pr["points"] and uy != 0:
                vals[f"ref_{name}"] = relative_error(pr["points"][name], uy)
        fields = ("ref_pressure_l2", "ref_pressure_l2_core", "ref_traction_l2")
        r.update({k: (math.nan if is_ref and (k in fields or not scalars) else v)
                  for k, v in vals.items()})
    add_orders(rows)
    return note


def relative_error(value: float, ref: float) -> float:
    """|value - ref| / |ref|; NaN when ref is 0 (e.g. the energy or peak pressure of a
    scene whose load is zero or whose contact never closes: no relative error to give)."""
    return abs(value - ref) / abs(ref) if ref != 0 else math.nan


def observed_order(coarse: float, fine: float) -> float:
    """log2(coarse / fine): the observed order of an error between two levels whose h
    halves; NaN unless both errors are positive."""
    return math.log2(coarse / fine) if coarse > 0 and fine > 0 else math.nan


def add_orders(rows: list[dict]) -> None:
    """order_<col> = log2(e_{l-1} / e_l) for every err_/ref_ column, per method."""
    cols = [k for k in dict.fromkeys(k for r in rows for k in r)
            if k.startswith(("err_", "ref_"))]
    for m in dict.fromkeys(r["method"] for r in rows):
        rr = sorted((r for r in rows if r["method"] == m), key=lambda r: r["level"])
        for prev, cur in zip(rr, rr[1:], strict=False):
            for c in cols:
                a, b = prev.get(c, math.nan), cur.get(c, math.nan)
                ok = cur["level"] == prev["level"] + 1
                cur[f"order_{c}"] = observed_order(a, b) if ok else math.nan


def energy_bracket(rows: list[dict]) -> list[dict]:
    """Per level with a 1SD run and a FEM-Q4 (else 16SD) run: both energies, the bracket
    width relative to their mean, the order of the width, and each method's energy error
    against the reference (ref_energy) for comparison with the width."""
    out = []
    for level in sorted({r["level"] for r in rows}):
        by = {r["method"]: r for r in rows if r["level"] == level}
        low = "FEM-Q4" if "FEM-Q4" in by else "16SD" if "16SD" in by else None
        if "1SD" not in by or low is None:
            continue
        u1, ul = by["1SD"]["strain_energy"], by[low]["strain_energy"]
        row = {"level": level, "n_dofs": by["1SD"]["n_dofs"], "U_1SD": u1,
               f"U_{low}": ul, "lower_method": low,
               "one_sd_is_upper": bool(u1 >= ul),
               "width_rel": relative_error(u1, ul) if u1 + ul == 0
               else abs(u1 - ul) / abs(0.5 * (u1 + ul))}
        for m, r in by.items():
            row[f"ref_energy_{m}"] = r.get("ref_energy", math.nan)
        out.append(row)
    for prev, cur in zip(out, out[1:], strict=False):
        ok = cur["level"] == prev["level"] + 1
        cur["order_width"] = (observed_order(prev["width_rel"], cur["width_rel"]) if ok
                              else math.nan)
    return out


def _fmt(v) -> str:
    if isinstance(v, float):
        return "" if math.isnan(v) else f"{v:.3g}"
    return str(v)


def write_tables(rows: list[dict], bracket: list[dict], out: Path, note: str,
                 marks: dict[tuple[str, str], dict[int, str]] | None = None,
                 timing: str = "") -> str:
    """Markdown tables (errors with observed orders per method; the energy bracket) in
    OUT/study_tables.md; returns the text. marks: {(method, column): {level: mark}} put
    after an order (app/studies/richardson_reference.order_marks: * fixed by the reference's own
    limit, ~ within its uncertainty, = against the reference at the same level); timing:
    a line under the errors' table on how its times (t_total) are counted."""
    cols = [k for k in dict.fromkeys(k for r in rows for k in r)
            if k.startswith(("err_", "ref_"))]
    lines = [f"errors (observed order in parentheses; *: fixed by the reference's own "
             f"Richardson limit, ~: an error within that limit's uncertainty, =: an error "
             f"against the reference run at the same level); {note}", "",
             "| method | level | DOFs | t_total [s] | " + " | ".join(c for c in cols) + " |",
             "|---" * (4 + len(cols)) + "|"]
    runs = {m: i for i, m in enumerate(dict.fromkeys(r["method"] for r in rows))}
    for r in sorted(rows, key=lambda r: (runs[r["method"]], r["level"])):  # --methods order
        cells = []
        for c in cols:
            o = r.get(f"order_{c}", math.nan)
            mark = (marks or {}).get((r["method"], c), {}).get(r["level"], "")
            cells.append(_fmt(r.get(c, math.nan))
                         + (f" ({o:.2f}{mark})" if math.isfinite(o) else ""))
        lines.append(f"| {r['method']} | {r['level']} | {r['n_dofs']} | {r['t_total']:.2f} | "
                     + " | ".join(cells) + " |")
    if timing:
        lines += ["", timing]
    if bracket:
        keys = list(dict.fromkeys(k for b in bracket for k in b))
        lines += ["", "energy bracket (width relative to the mean of the two bounds)", "",
                  "| " + " | ".join(keys) + " |", "|---" * len(keys) + "|"]
        lines += ["| " + " | ".join(_fmt(b.get(k, math.nan)) for k in keys) + " |"
                  for b in bracket]
    text = "\n".join(lines) + "\n"
    atomic_write_bytes(Path(out) / "study_tables.md", text.encode())  # whole or old
    return text


def plot_bracket(bracket: list[dict], out: Path) -> Path:
    """energy_bracket.png: the bracket width and each bound's energy error against the
    reference, against DOFs."""
    import matplotlib.ticker

    plt = pyplot()
    x = np.array([b["n_dofs"] for b in bracket], dtype=float)
    lv = np.array([b["level"] for b in bracket], dtype=float)
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    w = np.array([b["width_rel"] for b in bracket])
    ax.loglog(x, w, "ks-", label=f"bracket width (rate {fitted_rate(lv, w):.2f})")
    for k in dict.fromkeys(k for b in bracket for k in b):
        if k.startswith("ref_energy_"):
            y = np.array([b.get(k, math.nan) for b in bracket], dtype=float)
            if np.isfinite(y).sum() >= 1:
                ax.loglog(x, y, "o--", ms=3, label=f"|U-U_ref|/U_ref {k[11:]} "
                          f"(rate {fitted_rate(lv, y):.2f})")
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # (they overlapped)
    ax.set_xlabel("DOFs")
    ax.set_ylabel("relative energy")
    ax.set_title("energy bracket U(1SD) / U(" + bracket[0]["lower_method"] + ")", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "energy_bracket.png", dpi=90)
    plt.close(fig)
    return out / "energy_bracket.png"


def fitted_rate(levels: np.ndarray, err: np.ndarray) -> float:
    """Convergence rate in the element size h = H 2^-level of the study's levels (split or
    remeshed, h halves per level): the least-squares slope of log err against log h, so
    that two levels give their observed order log2(e_{l-1}/e_l). (Before, h ~ DOFs^-1/2,
    which read 2-7% above the orders: DOFs grow by less than 4 per level, e.g. 2532 ->
    9804 -> 38580 on hertz.toml.)"""
    ok = np.isfinite(err) & (err > 0)
    if ok.sum() < 2:
        return math.nan
    log_h = -np.asarray(levels, dtype=float)[ok] * math.log(2.0)
    return float(np.polyfit(log_h, np.log(err[ok]), 1)[0])
