"""Pictures of a result folder: the deformed mesh coloured by von Mises stress, and p(x),
q(x) along each interface with the closed form overlaid where the config names one (first
interface, last step only: summary.json's `reference` is the last step's).

    .venv/bin/python scripts/plot_results.py out/hertz [--step K] [--zoom X0 X1 Y0 Y1]
        [--scale S] [--prefix NAME]

Writes OUT/<prefix>deformed_von_mises.png and OUT/<prefix>contact_<interface>.png.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import sys
from pathlib import Path

import h5py
import numpy as np

from app.errors import InputError
from app.output import plot_mark
from app.plotting import pyplot
from app.references import REFERENCES, ContactProfile
from app.references.hertz import along_contact, contact_direction

plt = pyplot()  # Agg, without the warning of a second (Debian) matplotlib on the path
from matplotlib.collections import PolyCollection  # noqa: E402


def deformed_mesh(out: Path, step: int, zoom, scale: float | None, prefix: str) -> Path:
    with h5py.File(out / "mesh.h5") as f:
        pts, quads = f["points"][()], f["quads"][()]
    with h5py.File(out / f"step_{step:04d}.h5") as f:
        u = f["displacement"][()][:, :2]
        vm = f["von_mises"][()]
    size = np.ptp(pts, axis=0).max()
    umax = np.abs(u).max()
    if scale is None:
        scale = 0.05 * size / umax if umax > 0 else 1.0
    xy = pts + scale * u
    keep = np.ones(len(quads), dtype=bool)
    if zoom:
        c = xy[quads].mean(axis=1)
        keep = (c[:, 0] > zoom[0]) & (c[:, 0] < zoom[1]) & (c[:, 1] > zoom[2]) & (
            c[:, 1] < zoom[3])
        if not keep.any():  # an empty picture, before
            lo, hi = c.min(axis=0), c.max(axis=0)
            raise SystemExit(f"error: --zoom {' '.join(f'{z:g}' for z in zoom)}: no element "
                             f"of step {step} has its deformed centre in the box "
                             f"(displacements x {scale:.3g}: the centres span x "
                             f"{lo[0]:.4g}..{hi[0]:.4g}, y {lo[1]:.4g}..{hi[1]:.4g})")
    fig, ax = plt.subplots(figsize=(8, 5))
    pc = PolyCollection(xy[quads[keep]], array=vm[keep], cmap="viridis",
                        edgecolors="k", linewidths=0.05 if keep.sum() > 5000 else 0.2)
    ax.add_collection(pc)
    ax.autoscale()
    if zoom:
        ax.set_xlim(zoom[0], zoom[1])
        ax.set_ylim(zoom[2], zoom[3])
    ax.set_aspect("equal")
    fig.colorbar(pc, ax=ax, label="von Mises stress")
    ax.set_title(f"step {step}: deformed x {scale:.3g}, coloured by von Mises")
    path = out / safe_file_name(f"{prefix}deformed_von_mises.png")
    fig.tight_layout()
    fig.savefig(path, dpi=110, metadata=plot_mark.METADATA)  # (a rerun removes it)
    plt.close(fig)
    return path


def contact_coordinate(c: dict, sel: np.ndarray, ref: dict, name: str
                       ) -> tuple[np.ndarray, str]:
    """The pairs' coordinate along an interface and its axis label: with a contact
    reference (its `center_x`, `center_y`), center_x + s along the contact's own direction
    as the reference measures it (`app.references.hertz.along_contact`; x where they agree
    to 1e-6 of the span, an untilted scene), so that the closed form overlays a tilted
    contact; else x, or y for an
    interface that spans more in y."""
    x, y = c["x"][sel], c["y"][sel]
    if ref.get("type") in REFERENCES and "center_x" in ref and "tangent" in c and x.size:
        prof = ContactProfile(
            x=x, y=y, p=c["p"][sel], q=c["q"][sel], length=c["length"][sel],
            p_force=c["p_force"][sel], q_force=c["q_force"][sel],
            stick=np.zeros(x.size, bool), mu=0.0, E_star=1.0, interface=name,
            tangent=c["tangent"][sel])
        try:
            t = contact_direction(prof)
            s = along_contact({"center_x": ref["center_x"],
                               "center_y": ref.get("center_y")}, prof)
        except InputError:  # the run would have failed: not drawn against the contact
            t = None
        # x where the two agree to 1e-6 of the span (or |x|), invisible: an untilted scene whose
        # mean tangent is off by round-off (two arcs: t = (1, 2.2e-13)) is drawn along x
        along = None if t is None else ref["center_x"] + s
        span = max(float(np.ptp(x)), float(np.ptp(y)), float(np.abs(x).max()))
        if along is not None and not np.allclose(along, x, rtol=0.0, atol=1e-6 * span):
            return along, "center_x + distance along the contact"
    return (x, "x") if np.ptp(x) >= np.ptp(y) else (y, "y")


def contact_plots(out: Path, step: int, summary: dict, prefix: str) -> list[Path]:
    with h5py.File(out / f"step_{step:04d}.h5") as f:
        if "contact" not in f:
            return []
        c = {k: f["contact"][k][()] for k in f["contact"]}
    names = list(summary["steps"][step - 1].get("interfaces", {}))
    ref = summary.get("reference", {}) if step == len(summary["steps"]) else {}
    paths = []
    for i, name in enumerate(names):
        sel = c["interface"] == i
        coord, label = contact_coordinate(c, sel, ref if i == 0 else {}, name)
        o = np.argsort(coord)
        fig, axes = plt.subplots(2, 1, figsize=(7, 5.5), sharex=True)
        axes[0].plot(coord[o], c["p"][sel][o], "o-", ms=3, label="p (computed)")
        axes[1].plot(coord[o], c["q"][sel][o], "o-", ms=3, label="q (computed)")
        if i == 0 and ref.get("type") in REFERENCES:
            curves = REFERENCES[ref["type"]].overlay(ref, float(np.max(c["mu"][sel])))
            xx = np.linspace(coord.min(), coord.max(), 400)
            for ax, key in ((axes[0], "p"), (axes[1], "q")):
                if key in curves:
                    label_ref, curve = curves[key]
                    ax.plot(xx, curve(xx), "k--", lw=1, label=label_ref)
        state = c["state"][sel][o]
        for code, col in ((2, "tab:red"), (3, "tab:red"), (4, "0.7")):
            m = state == code
            axes[1].plot(coord[o][m], c["q"][sel][o][m], "s", ms=4, mfc="none", color=col)
        axes[0].set_ylabel("normal traction p")
        axes[1].set_ylabel("tangential traction q")
        axes[1].set_xlabel(f"{label} (red squares: slip, grey: open)")
        for ax in axes:
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8)
        axes[0].set_title(f"interface '{name}', step {step}")
        path = out / safe_file_name(f"{prefix}contact_{name}.png")
        fig.tight_layout()
        fig.savefig(path, dpi=110, metadata=plot_mark.METADATA)  # (a rerun removes it)
        plt.close(fig)
        paths.append(path)
    return paths


MAX_NAME = 120
"""Longest file name written (bytes); most file systems allow 255."""


def safe_file_name(name: str) -> str:
    """`name` with characters other than letters, digits, '.', '-', '_' replaced by '_',
    and shortened (keeping a hash of the full name and the extension) when too long."""
    clean = re.sub(r"[^A-Za-z0-9._-]", "_", name)
    if len(clean) <= MAX_NAME:
        return clean
    stem, dot, ext = clean.rpartition(".")
    digest = hashlib.sha1(name.encode()).hexdigest()[:10]
    return f"{stem[: MAX_NAME - len(ext) - 12]}_{digest}{dot}{ext}"


def check_step(out: Path, step: int | None) -> tuple[dict, int]:
    """The summary of OUT and the step to draw (the last by default); SystemExit(2) with one
    line naming the problem otherwise."""
    path = out / "summary.json"
    try:
        summary = json.loads(path.read_text())
        n = len(summary["steps"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SystemExit(f"error: {path}: not a readable result summary ({exc})") from None
    if n == 0:
        raise SystemExit(f"error: {out} has no completed step to draw")
    step = n if step is None else step
    if not 1 <= step <= n:
        raise SystemExit(f"error: --step {step}: {out} has steps 1..{n}")
    if not (out / f"step_{step:04d}.h5").is_file() or not (out / "mesh.h5").is_file():
        raise SystemExit(f"error: {out}: step_{step:04d}.h5 or mesh.h5 is missing")
    return summary, step


def check_view(zoom: list[float] | None, scale: float | None) -> None:
    """SystemExit(2) with one line for a --zoom box or --scale that cannot draw anything
    (before: NaN, inf or an inverted box drew an empty picture, exit 0)."""
    if scale is not None and not (np.isfinite(scale) and scale >= 0):
        raise SystemExit(f"error: --scale {scale:g}: a finite magnification >= 0 "
                         "(0 draws the undeformed mesh)")
    if zoom is not None and not (np.isfinite(zoom).all() and zoom[0] < zoom[1]
                                 and zoom[2] < zoom[3]):
        raise SystemExit(f"error: --zoom {' '.join(f'{z:g}' for z in zoom)}: X0 < X1 and "
                         "Y0 < Y1, finite")


def main() -> None:
    ap = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))
    ap.add_argument("out", type=Path)
    ap.add_argument("--step", type=int, default=None, help="default: the last step")
    ap.add_argument("--zoom", type=float, nargs=4, default=None, metavar=("X0", "X1", "Y0", "Y1"),
                    help="deformed mesh only: draw the elements whose centres lie in this box")
    ap.add_argument("--scale", type=float, default=None,
                    help="displacement magnification (default: the largest displacement "
                         "drawn as 5%% of the model's size)")
    ap.add_argument("--prefix", default="", help="put before every file name written")
    args = ap.parse_args()
    check_view(args.zoom, args.scale)
    summary, step = check_step(args.out, args.step)
    try:
        paths = [deformed_mesh(args.out, step, args.zoom, args.scale, args.prefix)]
        paths += contact_plots(args.out, step, summary, args.prefix)
    except OSError as exc:  # unwritable folder, full disk, unreadable step file
        raise SystemExit(f"error: {args.out}: {exc.strerror or exc}") from None
    for p in paths:
        print(p)


if __name__ == "__main__":
    try:
        main()
    except SystemExit as exc:
        if isinstance(exc.code, str):
            print(exc.code, file=sys.stderr)
            sys.exit(2)
        raise
