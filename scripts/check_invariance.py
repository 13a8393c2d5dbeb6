"""Run a scene and the same scene turned, mirrored, moved or rescaled; compare the answers.

    .venv/bin/python scripts/check_invariance.py CONFIG --interface NAME \
        [--discretisations mortar node-to-segment ...] [--xf angle=30 mirror=1 \
        scale=1000,Escale=1e-6,fscale=1e-3 shift=5:-3 ...] [--set KEY=VALUE ...] \
        [--mesh-size H] [--out DIR]

The scene is meshed once with the app's mesher (--mesh-size H: every element size times
H / mesh.size, as `python -m app run --mesh-size H`); its mesh is written as a gmsh .msh (the
identity and each transform x -> s R M x + t: R by `angle` degrees, M the mirror x -> -x
when `mirror=1`, s = `scale`, t = `shift`), and the config follows it: loads (vectors
turned, forces times `fscale`, default s), supports (vectors turned and scaled by s; a
one-component roller only for multiples of 90 deg), E times `Escale`, search_distance and
penetration_tol times s. Then p, the traction p n + q t (turned back), the states (slip+
and slip- swap under a mirror), the gaps and the strain energy of every step are compared
with the identity run's, scaled by ts = fscale / s (tractions), s ts / Escale (lengths) and
ts^2 s^2 / Escale (energy). One line per discretisation and transform; WORST is the largest
traction difference over max p. A frame change must agree to round-off. A CONFIG that
does not read, an --xf item that is not KEY=VALUE of those keys with numbers, or a scene
the app refuses stops with `error:` and exit 2 before any run.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
import subprocess
import sys
import tomllib
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from app.config import apply_overrides  # noqa: E402
from app.errors import InputError  # noqa: E402
from app.mesh.build import build_mesh  # noqa: E402
from app.scene.parse import parse_scene  # noqa: E402


def toml_value(x) -> str:
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, (int, float, str)):
        return json.dumps(x)
    if isinstance(x, (list, tuple)):
        return "[" + ", ".join(toml_value(v) for v in x) + "]"
    raise TypeError(f"cannot write {type(x).__name__} as TOML")


def toml_dumps(d: dict, prefix: str = "") -> str:
    """A TOML text of d (scalars, arrays, tables and arrays of tables)."""
    tab = [(k, v) for k, v in d.items() if isinstance(v, dict)]
    aot = [(k, v) for k, v in d.items()
           if isinstance(v, list) and v and all(isinstance(t, dict) for t in v)]
    skip = {k for k, _ in tab + aot}
    lines = [f"{k} = {toml_value(v)}" for k, v in d.items() if k not in skip]
    for k, v in tab:
        lines += [f"\n[{prefix}{k}]", toml_dumps(v, f"{prefix}{k}.")]
    for k, v in aot:
        for t in v:
            lines += [f"\n[[{prefix}{k}]]", toml_dumps(t, f"{prefix}{k}.")]
    return "\n".join(lines)


class Transform:
    """x -> s R M x + t and the scales of the answer (see the module docstring)."""

    KEYS = ("angle", "mirror", "scale", "shift", "Escale", "fscale")

    def __init__(self, text: str):
        """text: comma list of KEY=VALUE (KEYS); ValueError naming what is wrong."""
        kv = dict(item.split("=", 1) for item in text.split(",") if "=" in item) if text else {}
        bad = [i for i in text.split(",") if "=" not in i or i.split("=")[0] not in self.KEYS]
        if text and bad:
            raise ValueError(f"--xf {text}: {bad[0]!r} is not KEY=VALUE with KEY one of "
                             f"{', '.join(self.KEYS)} (e.g. angle=30 mirror=1 shift=5:-3)")
        try:
            self._set(kv)
        except ValueError:
            raise ValueError(f"--xf {text}: the values must be numbers (shift=X:Y, "
                             "mirror=1)") from None
        if self.s <= 0 or self.e <= 0 or self.f <= 0:
            raise ValueError(f"--xf {text}: scale, Escale and fscale must be positive")
        self.text = text or "identity"

    def _set(self, kv: dict[str, str]) -> None:
        t = math.radians(float(kv.get("angle", 0.0)))
        self.R = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
        self.deg = float(kv.get("angle", 0.0))
        self.Q = self.R @ (np.diag([-1.0, 1.0]) if kv.get("mirror") == "1" else np.eye(2))
        self.mirror = kv.get("mirror") == "1"
        self.s = float(kv.get("scale", 1.0))
        self.t = np.array([float(v) for v in kv.get("shift", "0:0").split(":")])
        if self.t.shape != (2,):
            raise ValueError("shift is X:Y")
        self.e = float(kv.get("Escale", 1.0))
        self.f = float(kv.get("fscale", self.s))
        self.ts = self.f / self.s
        self.us = self.ts * self.s / self.e

    def point(self, x) -> np.ndarray:
        return np.asarray(x, float) @ (self.s * self.Q).T + self.t

    def vector(self, v) -> np.ndarray:
        return self.Q @ np.asarray(v, float)


def write_msh(mesh, tf: Transform, path: Path) -> None:
    """The mesh moved by tf, as a gmsh 2.2 .msh (read back through mesh.file)."""
    write_msh_points(mesh, tf.point(mesh.points), path)


def write_msh_points(mesh, pts: np.ndarray, path: Path) -> None:
    """mesh's bodies (quads) and curves (lines) as physical groups of their names, at the
    node positions pts (n, 2), as a gmsh 2.2 .msh."""
    import meshio

    cells, phys, names = [], [], {}
    for b, name in enumerate(mesh.body_names):
        cells.append(("quad", mesh.quads[mesh.body == b]))
        names[name] = np.array([len(names) + 1, 2])
        phys.append(np.full(len(cells[-1][1]), len(names)))
    for name, e in mesh.curves.items():
        cells.append(("line", e))
        names[name] = np.array([len(names) + 1, 1])
        phys.append(np.full(len(e), len(names)))
    meshio.write(path, meshio.Mesh(np.column_stack([pts, np.zeros(len(pts))]), cells,
                                   cell_data={"gmsh:physical": phys,
                                              "gmsh:geometrical": phys}, field_data=names),
                 file_format="gmsh22", binary=False)


def turn_support(s: dict, tf: Transform) -> None:
    ux, uy = s.get("ux"), s.get("uy")
    if isinstance(ux, str) or isinstance(uy, str):
        raise ValueError(f"support on {s['on']}: expressions are not transformed")
    if ux is not None and uy is not None:
        s["ux"], s["uy"] = (float(c) for c in tf.vector([ux, uy]) * tf.s)
        return
    d = tf.vector([1.0, 0.0] if ux is not None else [0.0, 1.0])
    v = (ux if ux is not None else uy) * tf.s
    s.pop("ux", None)
    s.pop("uy", None)
    if abs(abs(d[0]) - 1) < 1e-12:
        s["ux"] = float(v * d[0])
    elif abs(abs(d[1]) - 1) < 1e-12:
        s["uy"] = float(v * d[1])
    else:
        raise ValueError(f"the roller on {s['on']} cannot be turned by {tf.deg:g} deg "
                         "(only by multiples of 90)")


def transformed_config(raw: dict, tf: Transform) -> dict:
    cfg = copy.deepcopy(raw)
    cfg["mesh"] = {"file": "mesh.msh"}
    cfg.pop("reference", None)
    for b in cfg["body"]:
        for k in ("shape", "size", "curves"):
            b.pop(k, None)
        b["E"] = float(b["E"]) * tf.e
        if "body_force" in b:
            b["body_force"] = [float(c) for c in tf.vector(b["body_force"]) * tf.ts / tf.s]
    if "points" in cfg:
        cfg["points"] = {k: [float(c) for c in tf.point(v)] for k, v in cfg["points"].items()}
    for ld in cfg.get("load", []):
        if "total_force" in ld:
            ld["total_force"] = [float(c) for c in tf.vector(ld["total_force"]) * tf.f]
        if "traction" in ld:
            ld["traction"] = [float(c) for c in tf.vector(ld["traction"]) * tf.ts]
        if "pressure" in ld:
            ld["pressure"] = float(ld["pressure"]) * tf.ts
    for s in cfg.get("support", []):
        turn_support(s, tf)
    for it in cfg.get("interface", []):
        for k in ("search_distance", "penetration_tol"):
            if k in it:
                it[k] = float(it[k]) * tf.s
        for k in ("a", "c"):
            if k in it:
                it[k] = float(it[k]) * tf.ts
    return cfg


def run(raw: dict, mesh, tf: Transform, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    write_msh(mesh, tf, folder / "mesh.msh")
    (folder / "scene.toml").write_text(toml_dumps(transformed_config(raw, tf)) + "\n")
    out = folder / "out"
    r = subprocess.run([sys.executable, "-m", "app", "run", str(folder / "scene.toml"),
                        "--out", str(out), "--quiet"], cwd=ROOT, capture_output=True,
                       text=True)
    if r.returncode:
        print(f"{folder}: the run failed: {r.stderr.strip().splitlines()[-1]}")
    return out


def contact(out: Path, k: int) -> dict:
    with h5py.File(out / f"step_{k:04d}.h5") as f:
        return {n: f["contact"][n][()] for n in f["contact"]}


def compare(a: Path, b: Path, tf: Transform) -> dict:
    """The largest differences of run b (transformed) from run a (identity)."""
    sa, sb = (json.loads((d / "summary.json").read_text()) for d in (a, b))
    worst = {"p": 0.0, "traction": 0.0, "gap": 0.0, "states": 0, "unmatched": 0}
    for k in range(1, len(sa["steps"]) + 1):
        A, B = contact(a, k), contact(b, k)
        xa = tf.point(A["position"])
        d = np.linalg.norm(xa[:, None] - B["position"][None], axis=2)
        j = d.argmin(axis=1)
        ok = d[np.arange(len(xa)), j] <= 1e-6 * np.ptp(B["position"], axis=0).max()
        worst["unmatched"] += int((~ok).sum()) + abs(len(xa) - len(B["position"]))
        j = j[ok]
        sc = max(float(np.abs(B["p"]).max(initial=0.0)), 1e-300)
        ta = (A["p"][:, None] * A["normal"] + A["q"][:, None] * A["tangent"])[ok] @ tf.Q.T
        tb = B["p"][:, None] * B["normal"] + B["q"][:, None] * B["tangent"]
        st = A["state"][ok]
        if tf.mirror:
            st = np.where(st == 2, 3, np.where(st == 3, 2, st))
        # gaps against the interface's displacements too: with every pair closed the gaps
        # are round-off (before, 0.97 on patch.toml: round-off over round-off)
        gsc = max(float(np.abs(B["gap"]).max(initial=0.0)),
                  float(np.abs(B.get("displacement", 0.0)).max(initial=0.0)), 1e-300)
        worst["p"] = max(worst["p"], float(np.abs(A["p"][ok] * tf.ts - B["p"][j]).max()) / sc)
        worst["traction"] = max(worst["traction"],
                                float(np.abs(ta * tf.ts - tb[j]).max()) / sc)
        worst["gap"] = max(worst["gap"], float(np.abs(A["gap"][ok] * tf.us - B["gap"][j])
                                               .max()) / gsc)
        worst["states"] += int((st != B["state"][j]).sum())
    ea = sa["strain_energy"] * tf.ts ** 2 * tf.s ** 2 / tf.e
    worst["energy"] = abs(ea - sb["strain_energy"]) / max(abs(sb["strain_energy"]), 1e-300)
    return worst


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config")
    ap.add_argument("--interface", default="0",
                    help="the [[interface]] (name or index) whose discretisation is set "
                         "(default: the first)")
    ap.add_argument("--discretisations", nargs="+", default=[None])
    ap.add_argument("--xf", nargs="+", default=["angle=30", "angle=90", "mirror=1"])
    ap.add_argument("--set", action="append", default=[])
    ap.add_argument("--mesh-size", type=float, default=None, metavar="H")
    ap.add_argument("--out", default="out/invariance")
    a = ap.parse_args()
    try:
        base = tomllib.loads(Path(a.config).read_text())
    except (OSError, tomllib.TOMLDecodeError) as exc:
        ap.error(f"config {a.config}: {exc}")
    try:
        transforms = [Transform(text) for text in a.xf]
    except ValueError as exc:
        ap.error(str(exc))
    if a.mesh_size is not None and not 0 < a.mesh_size < math.inf:
        ap.error(f"--mesh-size must be a number > 0 (got {a.mesh_size})")
    for disc in a.discretisations:
        sets = list(a.set)
        if disc is not None:
            sets.append(f'interface.{a.interface}.discretisation="{disc}"')
        try:
            raw = apply_overrides(base, sets)
        except InputError as exc:
            ap.error(str(exc))
        for tf in transforms:  # a transform the scene cannot take: before any run
            try:
                transformed_config(raw, tf)
            except ValueError as exc:
                ap.error(f"--xf {tf.text}: {exc}")
        try:
            scene = parse_scene(raw)
            scale = a.mesh_size / float(raw["mesh"]["size"]) if a.mesh_size else 1.0
            mesh = build_mesh(scene, scale, base_dir=Path(a.config).parent)
        except InputError as exc:
            ap.error(str(exc))
        folder = Path(a.out) / (disc or "default")
        ref = run(raw, mesh, Transform(""), folder / "identity")
        for text, tf in zip(a.xf, transforms, strict=True):
            out = run(raw, mesh, tf, folder / text.replace("=", "").replace(",", "_")
                      .replace(":", "_"))
            w = compare(ref, out, tf)
            print(json.dumps({"discretisation": disc, "transform": text, **w,
                              "WORST": max(w["p"], w["traction"])}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
