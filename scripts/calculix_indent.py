"""CalculiX 2.20 against the app on a fine arc pressed into a coarse block (configs/indent.toml):
is the striped p(x) of a fine slave on a coarse master the discretisation's or the mesh's?

    .venv/bin/python scripts/calculix_indent.py [--config configs/indent.toml]
        [--block-sizes 0.08 0.04 0.02] [--slaves arc block] [--contact face-to-face]
        [--penalty-factor 10] [--increments 1] [--set KEY=VALUE ...] [--plot /tmp/p.png]

For every block element size (`--set body.block.size=S`) and slave side (`arc`: the
config's slave; `block`: slave and master swapped), the app runs the config (its default
discretisation unless a --set says otherwise) and CalculiX runs the SAME mesh (the app's
gmsh mesh of the config, written as CPE4 by `calculix_deck.py`): the config's supports
(zero ones held throughout, the others reached in `--increments` increments), penalty
contact K = `--penalty-factor` x max E / h_c (h_c the smaller median edge length of the two
curves over |x| < `--contact-x`), the interface's mu with stick slope K; face-to-face
(CalculiX's segment-to-segment penalty), node-to-face (collocation at the slave nodes) or
mortar (dual multipliers; one layer of C3D8, `calculix_c3d8.py`; frictionless in both
codes; K regularises, `--penalty-factor 0`: hard contact).

CalculiX's p is recovered from its displacements (the slave body's internal forces at the
slave nodes over their tributary lengths, normal of the undeformed curve); `native` is its
own CPRESS (face-to-face only); mortar: its CPRESS (the multipliers). Per code: P (the
reaction on the cylinder's top), the closed slave nodes (p > 1e-3 max p) sorted by x with
p, and the largest deviation of p from a local quadratic over 5 neighbours
(`app.contact.smoothness.local_fit_deviation`, of max p) over all of them and two nodes in
from each end (`inside`). `balance`: CalculiX's slave contact force (recovered; mortar:
p x tributary length) against its reaction (relative). One JSON line per run.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
from app_runner import run_app
from calculix_c3d8 import face_nodes, write_deck_c3d8
from calculix_cattaneo import fail, run_ccx
from calculix_deck import (
    ContactDeck,
    Step,
    interface_curves,
    median_edge,
    parse_dat,
    parse_frd_contact,
    recovered_tractions,
    total_force,
    write_deck,
)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from app.config import load_config  # noqa: E402
from app.contact.mortar import nodal_normals  # noqa: E402
from app.contact.pairs import tributary_length  # noqa: E402
from app.contact.resolution import interior_deviation  # noqa: E402
from app.contact.smoothness import local_fit_deviation  # noqa: E402

CLOSED = 1e-3  # a CalculiX slave node is closed when its p > CLOSED x max p
CONTACT = {  # --contact: (CalculiX pair type, extra *SURFACE BEHAVIOR values)
    "face-to-face": ("SURFACE TO SURFACE", ()),
    "node-to-face": ("NODE TO SURFACE", (0.01, 0.5)),  # sigma_inf, spring distance c0
    "mortar": ("MORTAR", ()),  # written by calculix_c3d8.write_deck_c3d8 (C3D8, mu = 0)
}


def smoothness(x: np.ndarray, p: np.ndarray) -> dict:
    """Largest local-fit deviation of p (closed nodes) over all of them and two nodes in
    from each end (the stripe warning's figure), as fractions of max p."""
    inside = interior_deviation(np.c_[x, np.zeros_like(x)], p) if x.size else 0.0
    return {"fit_deviation": float(local_fit_deviation(x, p).max(initial=0.0)),
            "fit_deviation_inside": inside}


def profile(x: np.ndarray, p: np.ndarray) -> dict:
    """The closed nodes' x and p (sorted by x, 4 significant digits) and their smoothness."""
    o = np.argsort(x)
    return {"n_closed": int(x.size), "max_p": float(p.max(initial=0.0))} | smoothness(x, p) | {
        "x": [float(f"{v:.4g}") for v in x[o]], "p": [float(f"{v:.4g}") for v in p[o]]}


def side_sets(cfg, slave: str) -> list[str]:
    """--set strings that make the block the slave of interface 0 (none for the arc)."""
    itf = cfg.interfaces[0]
    if slave == "arc":
        return []
    return [f'interface.{itf.name}.slave="{itf.master}"',
            f'interface.{itf.name}.master="{itf.slave}"']


def supports(cfg, mesh) -> tuple[dict, dict, dict]:
    """(node sets, fixed {set: components}, prescribed {set: {component: value}}) of the
    config's supports at their last step (1-based CalculiX components)."""
    sets, fixed, moved = {}, {}, {}
    for s in cfg.supports:
        if any(isinstance(v, str) for v in s.values.values()):
            fail(f"support on {s.on}: expressions are not exported to CalculiX")
        sets[s.on] = mesh.curve_nodes(s.on)
        vals = {c + 1: float(v) * float(s.history[-1]) for c, v in s.values.items()}
        if any(vals.values()):
            moved[s.on] = vals
        else:
            fixed[s.on] = tuple(vals)
    return sets, fixed, moved


def build(cfg, a: argparse.Namespace):
    """(mesh, slave edges, deck, h_c) of the config's mesh and interface 0."""
    from app.driver.context import RunOptions
    from app.driver.model import build_scene_mesh

    if cfg.loads:
        fail("loads are not exported to CalculiX: prescribe the displacements instead")
    mesh = build_scene_mesh(cfg, RunOptions())
    itf = cfg.interfaces[0]
    slave, master, slave_faces, master_faces = interface_curves(mesh, itf.slave, itf.master)
    h_c = min(median_edge(mesh.points, e, a.contact_x) for e in (slave, master))
    K = a.penalty_factor * float(max(cfg.E)) / h_c
    sets, fixed, moved = supports(cfg, mesh)
    kind, extra = CONTACT[a.contact]
    deck = ContactDeck(
        points=mesh.points, quads=mesh.quads, body=mesh.body, node_sets=sets,
        slave_faces=slave_faces, master_faces=master_faces,
        E=[float(e) for e in cfg.E], nu=[float(v) for v in cfg.nu], thickness=cfg.thickness,
        penalty=K, mu=itf.mu, stick=K, fixed=fixed, steps=[Step(moved, a.increments)],
        print_sets=list(moved), pair_type=kind, behavior_extra=extra)
    return mesh, slave, deck, h_c


def ccx_result(cfg, mesh, slave, deck, dat: str, frd: str | None) -> dict:
    """P (reaction), balance, recovered and native p profiles of a CalculiX run."""
    tables = parse_dat(dat)
    tr = recovered_tractions(tables, deck, slave, cfg.plane)
    rf = total_force(tables)
    P = -float(rf[1])  # the moved support pulls the cylinder down: RF_y < 0
    f_slave = tr["force"].sum(axis=0)  # the contact force on the slave body
    x, p = tr["x"], tr["pn"]
    closed = p > CLOSED * p.max()
    out = {"P": P, "balance": float(abs(abs(f_slave[1]) - abs(P)) / abs(P)),
           "P_from_p": float(np.sum((p * tr["length"])[closed]) * cfg.thickness)}
    out |= profile(x[closed], p[closed])
    if frd:
        native = parse_frd_contact(frd, mesh.n_nodes)[-1][1][tr["node"], 3]
        shut = native > CLOSED * native.max()
        out["native"] = profile(x[shut], native[shut])
    return out


def mortar_result(cfg, mesh, slave, deck, dat: str, frd: str) -> dict:
    """P (reaction) and the p profile (CPRESS at the z = 0 slave nodes) of a CalculiX mortar
    run; balance: P against the sum of p x tributary length x |n_y| (dual multipliers: the
    nodal forces)."""
    tables = parse_dat(dat)
    rf = total_force(tables)
    P = -float(rf[1]) * cfg.thickness  # the deck is one unit thick
    nodes = np.setdiff1d(face_nodes(mesh.quads, deck.slave_faces),
                         np.concatenate(list(deck.node_sets.values())))
    p = parse_frd_contact(frd, 2 * mesh.n_nodes)[-1][1][nodes, 3]
    on, length = tributary_length(mesh.points, slave)
    normal = nodal_normals(mesh.points, slave, mesh.n_nodes)[0][nodes]
    fy = float(np.sum(p * length[np.searchsorted(on, nodes)] * np.abs(normal[:, 1])))
    x = mesh.points[nodes, 0]
    closed = p > CLOSED * p.max()
    return {"P": P, "balance": abs(fy * cfg.thickness - abs(P)) / abs(P)} | profile(
        x[closed], p[closed])


def ours_result(config: str, sets: list[str], moved: str) -> dict:
    """P (reaction on the moved support) and the closed pairs' p profile of an app run."""
    s = run_app(config, [x for st in sets for x in ("--set", st)], pairs=("x", "p"))
    if "error" in s:
        return {"error": s["error"][-300:]}
    c = s["last_step_pairs"]
    closed = c["p"] > 0
    P = -float(s["steps"][-1]["reactions"][f"support:{moved}"]["Fy"])
    return {"P": P} | profile(c["x"][closed], c["p"][closed])


def run_case(a: argparse.Namespace, size: float, side: str) -> dict:
    """One block size and slave side: the app's and CalculiX's figures."""
    base = load_config(ROOT / a.config, a.sets)
    mortar = a.contact == "mortar"
    frictionless = [f"interface.{base.interfaces[0].name}.mu=0.0"] if mortar else []
    sets = [*a.sets, *frictionless, f"body.{a.block}.size={size}", *side_sets(base, side)]
    cfg = load_config(ROOT / a.config, sets)
    mesh, slave, deck, h_c = build(cfg, a)
    folder = Path(tempfile.mkdtemp(prefix="calculix_indent_"))
    wall, ccx = None, {"error": "ccx failed (message on stderr)"}
    try:
        dat, wall = run_ccx((write_deck_c3d8 if mortar else write_deck)(deck), folder)
        frd = (folder / "job.frd").read_text() if a.contact != "node-to-face" else None
        ccx = (mortar_result(cfg, mesh, slave, deck, dat, frd) if mortar
               else ccx_result(cfg, mesh, slave, deck, dat, frd))
    except SystemExit:  # run_ccx printed why; the other cases still run
        pass
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    ours = ours_result(a.config, sets, deck.print_sets[0])
    return {"block_size": size, "slave": side, "block_x": block_x(cfg, mesh, a.block),
            "p_difference": p_difference(ours, ccx),
            "contact": a.contact, "h_c": h_c,
            "penalty": deck.penalty, "increments": a.increments, "mu": deck.mu,
            "n_elements": mesh.n_elements, "ccx_seconds": wall,
            "ours": ours,
            "calculix": ccx}


def p_difference(ours: dict, ccx: dict) -> float | None:
    """max |p_ours - p_ccx| / max p_ours over the nodes closed in both (same x), or None."""
    if "x" not in ours or "x" not in ccx:
        return None
    xo, xc = np.round(ours["x"], 3), np.round(ccx["x"], 3)
    both, io, ic = np.intersect1d(xo, xc, return_indices=True)
    if both.size == 0:
        return None
    dp = np.abs(np.asarray(ours["p"])[io] - np.asarray(ccx["p"])[ic])
    return float(dp.max() / ours["max_p"])


def block_x(cfg, mesh, block: str, x_max: float = 0.3) -> list[float]:
    """x of the block's nodes on interface 0 with |x| < x_max, sorted."""
    itf = cfg.interfaces[0]
    own = np.unique(mesh.quads[mesh.body == cfg.body_names.index(block)])
    curve = itf.slave if np.isin(mesh.curve_nodes(itf.slave), own).all() else itf.master
    x = np.sort(mesh.points[mesh.curve_nodes(curve), 0])
    return x[np.abs(x) < x_max].tolist()


def plot(rows: list[dict], path: str) -> None:
    """p(x) of both codes: one row of panels per slave side, one column per block size."""
    from app.plotting import pyplot

    plt = pyplot()

    sides = list(dict.fromkeys(r["slave"] for r in rows))
    sizes = list(dict.fromkeys(r["block_size"] for r in rows))
    fig, axes = plt.subplots(len(sides), len(sizes), figsize=(5 * len(sizes), 4 * len(sides)),
                             squeeze=False)
    for r in rows:
        ax = axes[sides.index(r["slave"]), sizes.index(r["block_size"])]
        for key, style, name in (("ours", "k.-", "app"), ("calculix", "b.-", "CalculiX")):
            pr = r[key]
            if "x" in pr:
                ax.plot(pr["x"], pr["p"], style,
                        label=f"{name} (fit deviation {100 * pr['fit_deviation']:.1f}%)")
        for xm in r["block_x"]:  # the block's nodes on the interface
            ax.axvline(xm, color="0.8", lw=0.8, zorder=0)
        ax.set(xlabel="x (grey: the block's nodes)", ylabel="p", xlim=(-0.25, 0.25),
               title=f"block {r['block_size']}, slave {r['slave']}, CalculiX {r['contact']}")
        ax.grid(True, axis="y")
        ax.legend(fontsize=7, loc="lower center")
    fig.tight_layout()
    fig.savefig(path, dpi=100)


def _arguments() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default="configs/indent.toml")
    ap.add_argument("--block", default="block", help="the [[body]] whose size is varied")
    ap.add_argument("--block-sizes", type=float, nargs="+", default=[0.08])
    ap.add_argument("--slaves", nargs="+", choices=("arc", "block"), default=["arc"])
    ap.add_argument("--contact", choices=tuple(CONTACT), default="face-to-face")
    ap.add_argument("--penalty-factor", type=float, default=10.0,
                    help="K = factor x max E / h_c (mortar: 0 for hard contact)")
    ap.add_argument("--contact-x", type=float, default=0.2,
                    help="h_c: median edge length over |x| < this")
    ap.add_argument("--increments", type=int, default=1)
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--plot", help="PNG of p(x), one panel per run")
    return ap.parse_args()


def main() -> None:
    a = _arguments()
    if shutil.which("ccx") is None:
        fail("ccx (CalculiX) not found on PATH; install calculix-ccx")
    rows = []
    for size in a.block_sizes:
        for side in a.slaves:
            rows.append(run_case(a, size, side))
            print(json.dumps(rows[-1]), flush=True)
    if a.plot:
        plot(rows, a.plot)


if __name__ == "__main__":
    main()
