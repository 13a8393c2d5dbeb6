"""Per-step figures of a run with a Mindlin-Deresiewicz load path (app/references/mindlin.py).

    .venv/bin/python scripts/mindlin_cycle.py OUT [--radius 1.0] [--center-x 0.0]
        [--top-y 1.0] [--json]

For every step of OUT (a `run --out` folder whose first interface is a cylinder on a flat
with the normal force held while the tangential force Q varies): Q / (mu P), the
interpolated and tributary L2 errors of q(x) against Masing's closed form (signed q), the
cumulative dissipation of the run against the closed form, and the load-point
displacement delta (the mean x displacement of the nodes at y = --top-y, the loaded flat
top, weighted by their tributary lengths: the displacement a uniform load there works
on). At the end, per closed cycle (a path from a turning point back to it through the
opposite one), the loop area by the trapezoid rule over the steps, the run's dissipation
over the cycle's steps and the closed form 4 D_v(Q*); the energy balance from step 1 on
(work of the tangential load minus the change of strain energy against the summed
dissipation); and the run's total dissipation against the closed form of its path.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import h5py
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from app.interface.steps import STICK  # noqa: E402
from app.output.read import read_pairs  # noqa: E402
from app.references.mindlin import (  # noqa: E402
    cycle_dissipation,
    masing_path,
    mindlin_errors,
    virgin_dissipation,
)


def load_point_displacement(out: Path, step: int, top_y: float) -> float:
    """Tributary-weighted mean ux of the mesh nodes at y = top_y."""
    with h5py.File(out / "mesh.h5") as f:
        pts = f["points"][()]
    with h5py.File(out / f"step_{step:04d}.h5") as f:
        u = f["displacement"][()]
    on = np.flatnonzero(np.abs(pts[:, 1] - top_y) < 1e-9 * max(1.0, abs(top_y)))
    on = on[np.argsort(pts[on, 0])]
    x = pts[on, 0]
    w = np.zeros(x.size)
    w[:-1] += 0.5 * np.diff(x)
    w[1:] += 0.5 * np.diff(x)
    return float(np.sum(w * u[on, 0]) / w.sum())


def closed_cycles(Q: np.ndarray) -> list[tuple[int, int, float]]:
    """(start, end, amplitude) of each closed cycle: a step at a turning point Q*, a later
    one at -Q* (turning), and a later one back at Q* (indices into Q)."""
    out = []
    turning = [k for k in range(1, Q.size - 1)
               if (Q[k] - Q[k - 1]) * (Q[k + 1] - Q[k]) < 0]
    for i, k in enumerate(turning):
        for j in turning[i + 1:]:
            if np.isclose(Q[j], -Q[k], rtol=1e-6):
                back = [n for n in range(j + 1, Q.size) if np.isclose(Q[n], Q[k], rtol=1e-6)]
                if back:
                    out.append((k, back[0], float(abs(Q[k]))))
                break
    return out


def analyse(out: Path, radius: float, center_x: float, top_y: float) -> dict:
    summary = json.loads((out / "summary.json").read_text())
    name = next(iter(summary["contact_interfaces"]))
    steps = summary["steps"]
    Q = np.array([s["interfaces"][name]["tangential_force"] for s in steps])
    P = np.array([s["interfaces"][name]["normal_force"] for s in steps])
    diss = np.array([s["interfaces"][name]["dissipation"] for s in steps])
    Q[np.abs(Q) <= 1e-9 * np.abs(Q).max(initial=0.0)] = 0.0
    ref = summary["reference"]
    e_star = None
    thick = float(summary["provenance"]["config_resolved"].get("analysis", {})
                  .get("thickness", 1.0))
    rows = []
    for k in range(1, len(steps) + 1):
        c = read_pairs(out / f"step_{k:04d}.h5", 0, ("x", "q", "p", "length", "interface", "mu",
                                                      "state"))
        x, q, length, p, state = (c[n] for n in ("x", "q", "length", "p", "state"))
        mu = float(c["mu"][0])
        if e_star is None:  # from the Hertz half-width the reference reported
            a_h, P_last = ref["hertz"]["a_hertz"], ref["hertz"]["P"]
            e_star = 4 * P_last / thick * radius / (np.pi * a_h**2)
        row = {"step": k, "Q_over_muP": float(Q[k - 1] / (mu * P[k - 1])),
               "delta": load_point_displacement(out, k, top_y),
               "dissipation": float(diss[:k].sum())}
        if Q[: k].any():
            m = mindlin_errors(x - center_x, q, length, Q_path=Q[:k], P=float(P[k - 1]), mu=mu,
                               R=radius, E_star=e_star, thickness=thick,
                               stick=(state == STICK) & (p > 0))
            row |= {"l2_interp": m["traction_l2_interp_rel_error"],
                    "stick": m.get("stick_half_width_rel_error", np.nan),
                    "l2_trib": m["traction_l2_rel_error"],
                    "dissipation_exact": m["dissipation_exact"]}
        rows.append(row)
    cycles = []
    for i, j, amp in closed_cycles(Q):
        d = np.array([r["delta"] for r in rows[i: j + 1]])
        qq = Q[i: j + 1]
        area = float(abs(np.sum(0.5 * (qq[1:] + qq[:-1]) * np.diff(d))))
        mu_P = float(amp / abs(rows[i]["Q_over_muP"]))
        exact = cycle_dissipation(amp, mu_P, e_star, thick)
        cycles.append({"from_step": i + 1, "to_step": j + 1, "Q_amplitude_over_muP": amp / mu_P,
                       "loop_area": area, "dissipation": float(diss[i + 1: j + 1].sum()),
                       "exact": exact, "loop_area_rel_error": abs(area - exact) / exact,
                       "dissipation_rel_error": abs(diss[i + 1: j + 1].sum() - exact) / exact})
    energy = energy_balance(steps, name, [r["delta"] for r in rows], diss)
    _, work, _ = masing_path(Q, lambda s: float(virgin_dissipation(s, mu_P_all(Q, P, rows),
                                                                e_star, thick)))
    return {"rows": rows, "cycles": cycles, "energy": energy,
            "dissipation_total": float(diss.sum()),
            "dissipation_total_exact": float(work[-1])}


def energy_balance(steps: list[dict], name: str, delta: list[float],
                   diss: np.ndarray) -> dict:
    """Work of the tangential load (the trapezoid rule over the steps, Q_x = minus the
    interface's x force on the slave) minus the change of strain energy, against the
    summed dissipation, from step 1 (the normal load, held after it) to the last."""
    qx = -np.array([s["interfaces"][name]["force"][0] for s in steps])
    d = np.asarray(delta)
    work = float(np.sum(0.5 * (qx[1:] + qx[:-1]) * np.diff(d)))
    stored = float(steps[-1]["strain_energy"] - steps[0]["strain_energy"])
    dissipated = float(diss[1:].sum())
    return {"external_work": work, "stored_energy_change": stored,
            "dissipation": dissipated, "residual": work - stored - dissipated,
            "residual_rel": (work - stored - dissipated) / dissipated if dissipated else
            float("nan")}


def mu_P_all(Q: np.ndarray, P: np.ndarray, rows: list[dict]) -> float:
    """mu P at the last step (from Q / (mu P) of a loaded step)."""
    k = int(np.flatnonzero(Q)[-1])
    return float(Q[k] / rows[k]["Q_over_muP"])


def plot(out: Path, res: dict, steps: list[int], center_x: float, radius: float,
         path: Path) -> None:
    """Left: Q / (mu P) against the load-point displacement (the loop); right: q / (mu p0)
    at `steps` against Masing's closed form (x / a)."""
    from app.closed_form import hertz_contact
    from app.plotting import pyplot
    from app.references.mindlin import masing_traction

    plt = pyplot()
    summary = json.loads((out / "summary.json").read_text())
    name = next(iter(summary["contact_interfaces"]))
    Q = np.array([s["interfaces"][name]["tangential_force"] for s in summary["steps"]])
    P = np.array([s["interfaces"][name]["normal_force"] for s in summary["steps"]])
    Q[np.abs(Q) <= 1e-9 * np.abs(Q).max(initial=0.0)] = 0.0
    rows = res["rows"]
    thick = float(summary["provenance"]["config_resolved"].get("analysis", {})
                  .get("thickness", 1.0))
    h = summary["reference"]["hertz"]
    e_star = 4 * h["P"] / thick * radius / (np.pi * h["a_hertz"] ** 2)
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(11, 4.2))
    # the loop is thin beside the elastic compliance: delta less the chord through its tips
    d, r = np.array([w["delta"] for w in rows]), np.array([w["Q_over_muP"] for w in rows])
    slope = (d[np.argmax(r)] - d[np.argmin(r)]) / (r.max() - r.min()) if np.ptp(r) else 0.0
    ax0.plot(d - slope * r, r, "o-", ms=3)
    ax0.set_xlabel("delta less the chord through the tips")
    ax0.set_ylabel("Q / (mu P)  (along the contact tangent)")
    for c in res["cycles"][:1]:
        ax0.set_title(f"loop area {c['loop_area']:.4g}, cycle dissipation "
                      f"{c['dissipation']:.4g} (closed form {c['exact']:.4g})", fontsize=9)
    for k in steps:
        c = read_pairs(out / f"step_{k:04d}.h5", 0, ("x", "q", "interface", "mu"))
        x, q, mu = c["x"] - center_x, c["q"], float(c["mu"][0])
        a, p0 = hertz_contact(P[k - 1] / thick, radius, e_star)
        terms, _, _ = masing_path(Q[:k], lambda s, mp=mu * P[k - 1]: float(
            virgin_dissipation(s, mp, e_star, thick)))
        win = np.abs(x) <= 1.2 * a
        line, = ax1.plot(x[win] / a, q[win] / (mu * p0), "o", ms=3,
                         label=f"step {k}, Q/(mu P) = {rows[k - 1]['Q_over_muP']:.3f}")
        xx = np.linspace(-1.2 * a, 1.2 * a, 801)
        ax1.plot(xx / a, masing_traction(xx, terms[-1], a, p0, mu, mu * P[k - 1]) / (mu * p0),
                 "-", lw=1, color=line.get_color())
    ax1.set_xlabel("x / a")
    ax1.set_ylabel("q / (mu p0): pairs (dots), Mindlin-Deresiewicz (lines)")
    ax1.legend(fontsize=8)
    for ax in (ax0, ax1):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--radius", type=float, default=1.0)
    ap.add_argument("--center-x", type=float, default=0.0)
    ap.add_argument("--top-y", type=float, default=1.0)
    ap.add_argument("--json", action="store_true", help="one JSON document instead of a table")
    ap.add_argument("--plot", type=Path, default=None,
                    help="PNG: the loop Q / (mu P) against delta, and q(x) at --steps")
    ap.add_argument("--steps", type=int, nargs="+", default=[6, 16, 35])
    args = ap.parse_args(argv)
    if not (args.out / "summary.json").is_file():
        ap.error(f"{args.out / 'summary.json'} not found: OUT must be the --out folder of a "
                 "run (configs/mindlin_cycle.toml)")
    res = analyse(args.out, args.radius, args.center_x, args.top_y)
    if args.plot is not None:
        plot(args.out, res, args.steps, args.center_x, args.radius, args.plot)
    if args.json:
        print(json.dumps(res))
        return 0
    print(f"{'step':>4} {'Q/muP':>8} {'L2 interp':>9} {'L2 trib':>8} {'stick':>7} "
          f"{'diss':>11} {'diss exact':>11} {'delta':>12}")
    for r in res["rows"]:
        print(f"{r['step']:4d} {r['Q_over_muP']:8.4f} {r.get('l2_interp', np.nan):9.4f} "
              f"{r.get('l2_trib', np.nan):8.4f} {r.get('stick', np.nan):7.4f} "
              f"{r['dissipation']:11.4e} "
              f"{r.get('dissipation_exact', np.nan):11.4e} {r['delta']:12.5e}")
    for c in res["cycles"]:
        print(json.dumps(c))
    print(json.dumps({"energy": res["energy"]}))
    print(json.dumps({"dissipation_total": res["dissipation_total"],
                      "dissipation_total_exact": res["dissipation_total_exact"]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
