"""CalculiX 2.20 on the issue-10 "CalculiX scene" of Cattaneo, on this project's own mesh.

    .venv/bin/python scripts/calculix_cattaneo.py [--mesh-size 0.25] [--normal-increments 5]
        [--normal-mu 0] [--ours OUT] [--plot /tmp/q.png] [--keep DIR]

The scene is `configs/cattaneo.toml` with the cylinder top held at ux = 0 while it is
pressed down by the config's approach uy (step 1, `--normal-increments`), then moved by
`--ux` (3e-3) in `--shear-increments` (10) increments (step 2): the run of
`python -m app run configs/cattaneo.toml --set 'load.0.total_force=[0.0,0.0]'
--set support.2.on=cyl_top --set support.2.ux=0.003 --set 'support.2.ramp=[6,15]'`.
The mesh is the app's (gmsh) mesh of that config (`--mesh-size` as in `run`; 0.25 gives
a/40), written as CPE4 with a face-based slave surface on the arc and the master on the
block top, face-to-face penalty contact with K = `--penalty-factor` x E / h_c (h_c the
median arc edge under the contact), Coulomb friction mu with stick slope K.

Tractions are recovered from CalculiX's displacements: the internal forces of the
cylinder's elements (CPE4 = bilinear, 2x2 Gauss) at the arc nodes, divided by the
tributary length. q is the traction on the cylinder against the shear motion (-f_x per
length, the convention of the app's q on this scene); the `arc` figures project the same
forces on the undeformed arc's nodal frame instead of the global x, y axes. The errors
are the app's (`app.closed_form.cattaneo_errors`: P, Q the sums of the recovered forces,
|q| interpolated linearly between nodes over |x| <= 1.5 a), the stick zone the nodes with
|q| < (1 - 1e-3) mu p. One JSON line per output time (end of the normal step, end), and
with `--ours OUT` the same figures of an app run folder at the end of its normal steps (the
cyl_top uy ramp's end, 5) and at its last step (15). Exit 2 with
a one-line message when `ccx` is missing or fails.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))
from calculix_deck import (  # noqa: E402
    ContactDeck,
    Step,
    interface_curves,
    median_edge,
    parse_dat,
    parse_frd_contact,
    recovered_tractions,
    times,
    total_force,
    write_deck,
)

from app.closed_form import cattaneo_errors, effective_moduli  # noqa: E402
from app.config import load_config  # noqa: E402

SCENE_SETS = ["load.0.total_force=[0.0,0.0]", "support.2.on=cyl_top", "support.2.ux=0.003",
              "support.2.ramp=[6,15]"]
STICK_TOL = 1e-3  # a node sticks when |q| < (1 - STICK_TOL) mu p


def fail(msg: str) -> None:
    print(f"error: {msg}", file=sys.stderr)
    raise SystemExit(2)


def normal_support(cfg):
    """The config's support pressing the cylinder down (uy on cyl_top)."""
    return [s for s in cfg.supports if s.on == "cyl_top" and 1 in s.values][0]


def normal_end(cfg) -> int:
    """The (1-based) step at which the normal support reaches its final value."""
    h = normal_support(cfg).history
    return int(np.argmax(h == h[-1])) + 1


def build(a: argparse.Namespace):
    """(config, mesh, deck) of the scene."""
    from app.driver.context import RunOptions
    from app.driver.model import build_scene_mesh

    cfg = load_config(ROOT / a.config, SCENE_SETS + a.sets)
    mesh = build_scene_mesh(cfg, RunOptions(mesh_scale=(a.mesh_size / cfg.mesh_size
                                                        if a.mesh_size else 1.0)))
    itf = cfg.interfaces[0]
    slave, _, slave_faces, master_faces = interface_curves(mesh, itf.slave, itf.master)
    h_c = median_edge(mesh.points, slave, 0.15)
    uy = normal_support(cfg).values[1]
    E = float(cfg.E[0])
    normal_mu = a.normal_mu
    deck = ContactDeck(
        points=mesh.points, quads=mesh.quads, body=mesh.body,
        node_sets={"base": mesh.curve_nodes("base"), "cyl_top": mesh.curve_nodes("cyl_top")},
        slave_faces=slave_faces, master_faces=master_faces,
        E=[float(e) for e in cfg.E], nu=[float(v) for v in cfg.nu], thickness=cfg.thickness,
        penalty=a.penalty_factor * E / h_c, mu=itf.mu, stick=a.stick_factor * a.penalty_factor
        * E / h_c, fixed={"base": (1, 2)},
        steps=[Step({"cyl_top": {1: 0.0, 2: float(uy)}}, a.normal_increments, normal_mu),
               Step({"cyl_top": {1: a.ux}}, a.shear_increments,
                    itf.mu if normal_mu is not None else None)],
        print_sets=["cyl_top"], nlgeom=a.nlgeom)
    return cfg, mesh, slave, deck, h_c


def run_ccx(deck_text: str, folder: Path) -> tuple[str, float]:
    """(.dat text, seconds) of `ccx -i job` in `folder`."""
    exe = shutil.which("ccx")
    if exe is None:
        fail("ccx (CalculiX) not found on PATH; install calculix-ccx")
    (folder / "job.inp").write_text(deck_text)
    env = dict(os.environ, OMP_NUM_THREADS="1", CCX_NPROC_EQUATION_SOLVER="1")
    t0 = time.perf_counter()
    res = subprocess.run([exe, "-i", "job"], cwd=folder, env=env, capture_output=True,
                         text=True)
    wall = time.perf_counter() - t0
    (folder / "job.log").write_text(res.stdout + res.stderr)
    errors = [ln.strip() for ln in res.stdout.splitlines() if "*ERROR" in ln]
    if res.returncode or errors or not (folder / "job.dat").exists():
        fail(f"ccx failed in {folder} ({errors[0] if errors else res.returncode})")
    return (folder / "job.dat").read_text(), wall


def profile_errors(x, p, q, length, *, mu, R, E_star, thickness, stick=None) -> dict:
    """Cattaneo-Mindlin figures of a traction profile (q against the shear, x sorted)."""
    P = float(np.sum(p * length) * thickness)
    Q = float(np.sum(q * length) * thickness)
    if stick is None:
        stick = (p > 1e-3 * p.max()) & (np.abs(q) < (1 - STICK_TOL) * mu * p)
    e = cattaneo_errors(x, p, q, length, stick, P=P, Q=Q, mu=mu, R=R, E_star=E_star,
                        thickness=thickness)
    return {k: e[k] for k in ("P", "Q", "Q_over_muP", "a_hertz", "stick_edges",
                              "stick_half_width_exact", "traction_l2_interp_rel_error",
                              "traction_l2_rel_error")}


def locked(x, p, q, mu, a_h) -> dict:
    """Size and antisymmetry of a tangential traction (no shear applied yet)."""
    p0 = float(p.max())
    inside = np.abs(x) <= a_h
    qi = q[inside]
    mirror = np.interp(-x[inside], x, q)
    return {"max_abs_q_over_mu_p0": float(np.abs(qi).max() / (mu * p0)),
            "q_at": float(x[inside][np.argmax(np.abs(qi))]),
            "symmetric_part_over_max": float(np.abs(qi + mirror).max() / 2 / np.abs(qi).max())}


def frames(tr: dict) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """(p, q) of recovered tractions: global axes, and the arc's nodal frame (undeformed,
    and deformed at the output time)."""
    return {"xy": (tr["fy"], -tr["fx"]), "arc": (tr["pn"], -tr["qt"]),
            "arc_def": (tr["pn_def"], -tr["qt_def"])}


def e_star(cfg) -> float:
    """The plane-strain (or stress) E* of the two equal bodies (body 0's E, nu)."""
    return effective_moduli(float(cfg.E[0]), float(cfg.nu[0]), cfg.plane)[0] / 2


def ccx_rows(cfg, mesh, slave, deck, dat: str, frd: str | None = None, *,
             E_star: float) -> list[dict]:
    """One row per output time: recovered P, Q, errors (end) or the locked-in q (normal);
    `native`: CalculiX's own nodal CPRESS and CSHEAR1 (sign: Q > 0 at the end) from `frd`."""
    tables = parse_dat(dat)
    native = {round(t, 9): v for t, v in parse_frd_contact(frd, mesh.n_nodes)} if frd else {}
    mu, R = deck.mu, cfg.reference["radius"]
    rows = []
    for t in times(tables, "displacements", "NALL"):
        # the arc's ends are supported (cyl_top): recovered_tractions drops them
        tr = recovered_tractions(tables, deck, slave, cfg.plane, t)
        o = np.argsort(tr["x"])
        tr = {k: v[o] for k, v in tr.items()}
        rf = total_force(tables, "cyl_top", t)
        row = {"code": "calculix", "time": t, "n_elements": mesh.n_elements,
               "rf_cyl_top": rf[:2].tolist() if rf is not None else None}
        for name, (p, q) in frames(tr).items():
            e = profile_errors(tr["x"], p, q, tr["length"], mu=mu, R=R, E_star=E_star,
                               thickness=cfg.thickness)
            row[name] = e | locked(tr["x"], p, q, mu, e["a_hertz"])
        if round(t, 9) in native:
            nat = native[round(t, 9)][tr["node"]]
            sign = -1.0 if np.sum(native[max(native)][tr["node"], 4] * tr["length"]) < 0 else 1.0
            e = profile_errors(tr["x"], nat[:, 3], sign * nat[:, 4], tr["length"], mu=mu, R=R,
                               E_star=E_star, thickness=cfg.thickness)
            row["native"] = e | locked(tr["x"], nat[:, 3], sign * nat[:, 4], mu,
                                       row["xy"]["a_hertz"])
            row["_native"] = (nat[:, 3], sign * nat[:, 4])
        row["_profile"] = {"x": tr["x"], "p": tr["fy"], "q": -tr["fx"], "p_arc": tr["pn"],
                           "q_arc": -tr["qt"], "q_def": -tr["qt_def"]}
        rows.append(row)
    return rows


def ours_rows(out: Path, cfg, E_star: float) -> list[dict]:
    """The same figures of an app run folder at the end of the normal steps (`normal_end`
    of cfg) and at its last step (`_end`: True)."""
    from app.output.read import read_pairs

    last = len(json.loads((out / "summary.json").read_text())["steps"])
    rows = []
    for step in (normal_end(cfg), last):
        c = read_pairs(out / f"step_{step:04d}.h5", 0, ("x", "p", "q", "length", "state"))
        stick = c["state"] == 1
        e = profile_errors(c["x"], c["p"], c["q"], c["length"], mu=cfg.interfaces[0].mu,
                           R=cfg.reference["radius"], E_star=E_star, thickness=cfg.thickness,
                           stick=stick if step == last else None)
        rows.append({"code": "ours", "out": str(out), "step": step,
                     "xy": e | locked(c["x"], c["p"], c["q"], cfg.interfaces[0].mu,
                                      e["a_hertz"]),
                     "_profile": {"x": c["x"], "p": c["p"], "q": c["q"]}, "_end": step == last})
    return rows


def plot(rows: list[dict], path: str, mu: float, R: float, E_star: float, thickness: float,
         ux: float) -> None:
    """q(x) after the normal step and at the end (shear motion ux): CalculiX (global axes
    and its own frame), the app run if given, and Cattaneo-Mindlin with the CalculiX end
    row's P, Q."""
    from app.plotting import pyplot

    plt = pyplot()

    from app.closed_form import cattaneo_traction, hertz_contact

    fig, axes = plt.subplots(1, 2, figsize=(13, 5))
    for r in rows:
        end = r.get("_end", r.get("time", 0.0) > 1.5)
        ax, pr = axes[int(end)], r["_profile"]
        if r["code"] == "calculix":
            ax.plot(pr["x"], pr["q"], "b.-", label="CalculiX, recovered, x axis")
            ax.plot(pr["x"], pr["q_def"], "g.-", label="CalculiX, recovered, deformed arc frame")
            if "_native" in r:
                ax.plot(pr["x"], r["_native"][1], "m.--", label="CalculiX CSHEAR1 (its frame)")
        else:
            ax.plot(pr["x"], pr["q"], "k.-", label=f"app, step {r['step']}")
    end = [r for r in rows if r["code"] == "calculix" and r["time"] > 1.5]
    if end:
        e = end[-1]["xy"]
        a_h, p0 = e["a_hertz"], hertz_contact(e["P"] / thickness, R, E_star)[1]
        xs = np.linspace(-1.5 * a_h, 1.5 * a_h, 601)
        axes[1].plot(xs, cattaneo_traction(xs, a_h, p0, mu, e["Q_over_muP"]), "r-",
                     label="Cattaneo-Mindlin")
        for ax in axes:
            ax.set_xlim(-1.5 * a_h, 1.5 * a_h)
    for ax, title in zip(axes, ("after the normal step", f"end (ux = {ux:g})"), strict=True):
        ax.set(xlabel="x", ylabel="q, traction on the cylinder against the shear", title=title)
        ax.grid(True)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def _arguments() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default="configs/cattaneo.toml")
    ap.add_argument("--mesh-size", type=float, default=None,
                    help="global element size as in `run` (0.25: a/40 on cattaneo.toml)")
    ap.add_argument("--normal-increments", type=int, default=1)
    ap.add_argument("--shear-increments", type=int, default=10)
    ap.add_argument("--normal-mu", type=float, default=None,
                    help="friction coefficient during the normal step (default: the config's)")
    ap.add_argument("--ux", type=float, default=0.003)
    ap.add_argument("--penalty-factor", type=float, default=10.0, help="K = factor x E / h_c")
    ap.add_argument("--stick-factor", type=float, default=1.0, help="stick slope = factor x K")
    ap.add_argument("--nlgeom", action="store_true",
                    help="geometrically nonlinear steps (the bulk as well as the contact)")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--ours", type=Path, help="an app run folder of the same scene to compare")
    ap.add_argument("--plot", help="PNG of the q(x) profiles")
    ap.add_argument("--keep", type=Path, help="keep the CalculiX job in this folder")
    ap.add_argument("--dat", type=Path, help="read this job.dat instead of running ccx")
    return ap.parse_args()


def _ccx_output(a: argparse.Namespace, text: str) -> tuple[str, str | None, float | None]:
    """(job.dat text, job.frd text or None, ccx wall seconds or None): from --dat, or a
    ccx run in --keep or a temporary folder."""
    if a.dat is not None:
        frd_path = a.dat.with_suffix(".frd")
        return a.dat.read_text(), frd_path.read_text() if frd_path.exists() else None, None
    folder = a.keep or Path(tempfile.mkdtemp(prefix="calculix_"))
    folder.mkdir(parents=True, exist_ok=True)
    try:
        dat, wall = run_ccx(text, folder)
        frd = (folder / "job.frd").read_text() if (folder / "job.frd").exists() else None
    finally:
        if a.keep is None:
            shutil.rmtree(folder, ignore_errors=True)
    return dat, frd, wall


def main() -> None:
    a = _arguments()
    if a.dat is None and shutil.which("ccx") is None:
        fail("ccx (CalculiX) not found on PATH; install calculix-ccx")
    cfg, mesh, slave, deck, h_c = build(a)
    dat, frd, wall = _ccx_output(a, write_deck(deck))
    E_star = e_star(cfg)
    rows = ccx_rows(cfg, mesh, slave, deck, dat, frd, E_star=E_star)
    if a.ours:
        rows += ours_rows(a.ours, cfg, E_star)
    head = {"mesh_size": a.mesh_size, "h_c": h_c, "penalty": deck.penalty,
            "normal_increments": a.normal_increments, "shear_increments": a.shear_increments,
            "normal_mu": a.normal_mu, "nlgeom": a.nlgeom, "ccx_seconds": wall}
    for r in rows:
        if r.get("code") == "calculix" and r["time"] not in (1.0, 2.0):
            continue
        print(json.dumps(head | {k: v for k, v in r.items() if not k.startswith("_")}),
              flush=True)
    if a.plot:
        plot([r for r in rows if r.get("time", 1.0) in (1.0, 2.0)], a.plot, deck.mu,
             cfg.reference["radius"], E_star, cfg.thickness, a.ux)


if __name__ == "__main__":
    main()
