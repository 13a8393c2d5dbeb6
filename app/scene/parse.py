"""The geometry part of a config ([mesh], [[body]] shapes and curves, [points]) parsed
into typed dataclasses, once, at the edge; the mesh builder and the size estimate take
the `Scene`. Lengths in config units, before any mesh-size scaling."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from app.config_keys import suggestion
from app.errors import InputError
from app.scene.geometry import Piece
from app.scene.geometry import is_number as _is_number
from app.scene.geometry import number as _number
from app.scene.geometry import xy_point as _xy
from app.scene.mesh_algorithms import DEFAULT_MESH_ALGORITHM, mesh_algorithm
from app.scene.shapes import SHAPES

REFINE_KEYS = ("curves", "points", "size", "distance", "flat")
PATCH_KEYS = ("box", "size")
GMSH_ONLY_KEYS = ("refine", "patch", "algorithm")
MAX_NAMED_POINTS = 1000
"""[points] names at most: each is matched to its node by a search of every mesh node, and
written per step; 100,000 of them (2.5 MB) ran patch.toml for 106 s into a 14.9 MB
summary.json."""
MAX_ZONES = 1000
"""[[mesh.refine]] and [[mesh.patch]] entries at most, each: every entry is a gmsh size
field per body, and gmsh's time to add one grows with the fields there are (5000 entries
meshed patch.toml's two blocks in 17.6 s, 10,000 in 88 s; `python -m app run`, its `mesh`
line). Points or curves sharing a size go into one entry."""
"""[mesh] keys of the gmsh builder: an error with mesh.file."""
POINT_TOL = 1e-6  # named points must lie within POINT_TOL * body size of a mesh node


@dataclass
class Side:
    """One named side of a body shape, made of consecutive pieces."""

    name: str  # shape side name (bottom, arc, side0, ...)
    curve: str | None  # physical curve name, None if unnamed
    pieces: list[Piece]


@dataclass
class BodySpec:
    """Validated geometry of one body; sides run counter-clockwise around it."""

    name: str
    size: float  # element size (config units, before `scale`)
    shape: dict[str, Any]
    structured: bool
    sides: list[Side]
    interior_points: list[np.ndarray] = field(default_factory=list)  # to embed

    def curve_pieces(self, curve: str) -> list[Piece]:
        """The geometry pieces of the named curve, in side order."""
        return [p for s in self.sides if s.curve == curve for p in s.pieces]

    def contains(self, xy: np.ndarray, tol: float) -> bool:
        """True if xy lies strictly inside the body (further than tol from its boundary)."""
        return SHAPES[self.shape["type"]].contains(self.shape, xy, tol)


@dataclass
class Refine:
    """One validated `[[mesh.refine]]` entry (lengths in config units)."""

    curves: list[str]
    points: np.ndarray  # (k, 2)
    size: float
    distance: float
    flat: float


@dataclass
class Patch:
    """One validated `[[mesh.patch]]`: structured quads of `size` inside `box`
    [xmin, ymin, xmax, ymax] in every body it meets (app/mesh/patch.py)."""

    box: np.ndarray  # (4,) xmin, ymin, xmax, ymax
    size: float


@dataclass
class Scene:
    """Validated geometry part of a config."""

    size: float
    file: str | None
    bodies: list[BodySpec]
    refine: list[Refine]
    points: dict[str, np.ndarray]  # named points
    source: dict = field(default_factory=dict)  # the geometry tables as written: cache key
    algorithm: str = DEFAULT_MESH_ALGORITHM  # gmsh recipe (app/scene/mesh_algorithms.py)
    patches: list[Patch] = field(default_factory=list)  # [[mesh.patch]]


# ----------------------------------------------------------------------------- parsing


def _table(v: Any, what: str) -> dict:
    if not isinstance(v, dict):
        raise InputError(f"{what} must be a table (got {v!r})")
    return v


def _shape_sides(shape: dict, where: str) -> tuple[list[tuple[str, list[Piece]]], bool]:
    """Sides (name, pieces) counter-clockwise and the `structured` flag of a shape table."""
    kind = shape.get("type")
    if not isinstance(kind, str) or kind not in SHAPES:
        raise InputError(
            f"{where}shape.type must be one of {', '.join(SHAPES)} (got {kind!r})"
        )
    spec = SHAPES[kind]
    w = f"{where}shape."
    allowed = ("type", "structured", "divisions", *spec.keys)
    for key in shape:
        if key not in allowed:
            raise InputError(
                f"{w}{key} is not a key of a {kind}{suggestion(key, allowed)} (keys: "
                f"{', '.join(allowed)})"
            )
    structured = shape.get("structured", False)
    if not isinstance(structured, bool):
        raise InputError(f"{w}structured must be true or false (got {structured!r})")
    if structured and not spec.structured:
        kinds = " or ".join(f'"{n}"' for n, sh in SHAPES.items() if sh.structured)
        raise InputError(f"{w}structured is only supported for type = {kinds}")
    if "divisions" in shape:
        dv = shape["divisions"]
        if not structured:
            raise InputError(f"{w}divisions needs structured = true")
        if (not isinstance(dv, list) or len(dv) != 2
                or not all(isinstance(k, int) and not isinstance(k, bool) and k >= 1
                           for k in dv)):
            raise InputError(f"{w}divisions must be [nx, ny], two integers >= 1 (got {dv!r})")
    return spec.sides(shape, w), structured


MIN_SIDE_RATIO = 1e-9
"""Shortest side accepted, relative to the longest side of the same body."""


def _check_side_lengths(sides: list[tuple[str, list[Piece]]], where: str) -> None:
    """Every side of a shape has a finite length above MIN_SIDE_RATIO of the longest."""
    lengths = {name: sum(p.length for p in pieces) for name, pieces in sides}
    longest = max(lengths.values())
    for name, length in lengths.items():
        if not (math.isfinite(length) and length > MIN_SIDE_RATIO * longest):
            raise InputError(f"{where}shape is degenerate: side {name} has length {length:.3g} "
                             f"against {longest:.3g} for the longest: check its dimensions")


def _split_at(pieces: list[Piece], xy: np.ndarray, tol: float) -> list[Piece]:
    out: list[Piece] = []
    for piece in pieces:
        t = piece.locate(xy, tol)
        out.extend(piece.split(t) if t is not None else [piece])
    return out


def parse_scene(cfg: dict, *, need_shapes: bool | None = None) -> Scene:
    """Validate the geometry part of a config ([mesh], [[body]], [points]).

    need_shapes: False when the mesh comes from a file (body shapes are then not used);
    by default, True unless mesh.file is set. Raises InputError naming the offending key.
    """
    if need_shapes is None:
        need_shapes = not (isinstance(cfg.get("mesh"), dict) and cfg["mesh"].get("file"))
    mesh = _table(cfg.get("mesh"), "[mesh]") if "mesh" in cfg else None
    if mesh is None:
        raise InputError("[mesh] section is missing: it needs at least size = <element size>")
    file = mesh.get("file")
    if file is not None and (not isinstance(file, str) or not file):
        raise InputError(f"mesh.file must be a file name (got {file!r})")
    for key in GMSH_ONLY_KEYS:  # (they were silently ignored)
        if file is not None and key in mesh:
            raise InputError(f"mesh.{key} does not apply to a mesh read from mesh.file "
                             f"({file}): it acts on the meshes built with gmsh here (refine "
                             "the file's mesh in gmsh, or split it with --refine)")
    size = math.nan if file is not None and "size" not in mesh else _number(mesh, "size",
                                                                            "mesh.")
    points_cfg = _table(cfg.get("points", {}), "[points]")
    if len(points_cfg) > MAX_NAMED_POINTS:
        raise InputError(f"[points] has {len(points_cfg)} names, more than "
                         f"{MAX_NAMED_POINTS}: name only the points supports, loads and "
                         "references use")
    named = {name: _xy(v, f"points.{name}") for name, v in points_cfg.items()}
    bodies_cfg = cfg.get("body")
    if not isinstance(bodies_cfg, list) or not bodies_cfg:
        raise InputError("[[body]] is missing: the config needs at least one body")
    bodies: list[BodySpec] = []
    curve_owner: dict[str, str] = {}
    for i, b in enumerate(bodies_cfg):
        bodies.append(_body(_table(b, f"body[{i}]"), i, size, need_shapes, named, bodies,
                            curve_owner))
    for pname in named:
        if pname in curve_owner:
            raise InputError(f"points.{pname}: the name is already used by a curve")
    ref_cfg = mesh.get("refine", [])
    if not isinstance(ref_cfg, list):
        raise InputError("mesh.refine must be an array of tables [[mesh.refine]]")
    _check_zone_count(ref_cfg, "refine", "its points or curves into fewer entries")
    refine = [_refine(_table(r, f"mesh.refine[{i}]"), f"mesh.refine[{i}].",
                      curve_owner if need_shapes else None) for i, r in enumerate(ref_cfg)]
    source = {"bodies": [{k: b.get(k) for k in ("name", "shape", "size", "curves")}
                         for b in bodies_cfg],
              "mesh": mesh, "points": cfg.get("points", {})}
    algorithm = mesh_algorithm(mesh.get("algorithm", DEFAULT_MESH_ALGORITHM))
    patch_cfg = mesh.get("patch", [])
    if not isinstance(patch_cfg, list):
        raise InputError("mesh.patch must be an array of tables [[mesh.patch]]")
    _check_zone_count(patch_cfg, "patch", "the boxes into fewer, larger ones")
    patches = [_patch(_table(r, f"mesh.patch[{i}]"), f"mesh.patch[{i}].")
               for i, r in enumerate(patch_cfg)]
    return Scene(size, file, bodies, refine, named, source, algorithm, patches)


def _body(b: dict, i: int, size: float, need_shapes: bool, named: dict[str, np.ndarray],
          earlier: list[BodySpec], curve_owner: dict[str, str]) -> BodySpec:
    """One [[body]]'s geometry; `curve_owner` (curve name -> body) is filled in."""
    name = b.get("name")
    if not isinstance(name, str) or not name:
        raise InputError(f"body[{i}].name must be a non-empty string (got {name!r})")
    if any(x.name == name for x in earlier):
        raise InputError(f"body name '{name}' is used twice: body names must be unique")
    where = f"body '{name}': "
    bsize = _number(b, "size", where) if "size" in b else size
    if not need_shapes:
        for key, table in (("shape", "[body.shape]"), ("curves", "[body.curves]")):
            if key in b:  # (ignored without a word before: a shape unlike the file's ran)
                raise InputError(f"{where}{key} does not apply to a mesh read from mesh.file: "
                                 "the .msh gives the geometry and its physical groups the "
                                 f"curves; remove {table} (or mesh.file to build the shape)")
        return BodySpec(name, bsize, {}, False, [])
    if "shape" not in b:
        raise InputError(f"{where}shape is missing: add a [body.shape] table with a type")
    shape = _table(b["shape"], f"{where}shape")
    raw_sides, structured = _shape_sides(shape, where)
    _check_side_lengths(raw_sides, where)
    curves = _table(b.get("curves", {}), f"{where}curves")
    _check_curves(curves, [s for s, _ in raw_sides], shape["type"], name, where, curve_owner)
    tol = POINT_TOL * bsize
    sides = []
    for sname, pieces in raw_sides:
        for xy in named.values():  # geometry vertex at every named point on a side
            pieces = _split_at(pieces, xy, tol)
        sides.append(Side(sname, curves.get(sname), pieces))
    spec = BodySpec(name, bsize, shape, structured, sides)
    if not structured:
        spec.interior_points = [xy for xy in named.values() if spec.contains(xy, tol)]
    return spec


def listed(names: list[str], most: int = 12) -> str:
    """The names, comma-separated; of more than `most`, the first ones and the last (a
    10,000-corner polygon's error line listed all its sides, 119 kB)."""
    if len(names) <= most:
        return ", ".join(names)
    return f"{', '.join(names[:most - 2])}, ... ({len(names)} in all), {names[-1]}"


def _check_curves(curves: dict, valid: list[str], kind: str, name: str, where: str,
                  curve_owner: dict[str, str]) -> None:
    """[body.curves]: each key a side of the shape, each name owned by one body."""
    for side, cname in curves.items():
        if side not in valid:
            raise InputError(
                f"{where}curves.{side} is not a side of a {kind}"
                f"{suggestion(side, valid)} (sides: {listed(valid)})"
            )
        if not isinstance(cname, str) or not cname:
            raise InputError(f"{where}curves.{side} must be a curve name (got {cname!r})")
        owner = curve_owner.setdefault(cname, name)
        if owner != name:
            raise InputError(
                f"curve name '{cname}' is used by bodies '{owner}' and '{name}': "
                "each body needs its own curve names"
            )


def _check_zone_count(entries: list, kind: str, merge: str) -> None:
    """InputError when [[mesh.KIND]] has more than MAX_ZONES entries."""
    if len(entries) > MAX_ZONES:
        raise InputError(f"mesh.{kind} has {len(entries)} entries, more than {MAX_ZONES}: "
                         f"gather {merge} (meshing time grows faster than the entries)")


def _refine(r: dict, where: str, curve_owner: dict[str, str] | None) -> Refine:
    """One [[mesh.refine]] (curves checked against `curve_owner` unless None)."""
    for key in r:
        if key not in REFINE_KEYS:
            raise InputError(f"{where}{key} is not a refinement key ({', '.join(REFINE_KEYS)})")
    rc = r.get("curves", [])
    if not isinstance(rc, list) or not all(isinstance(c, str) for c in rc):
        raise InputError(f"{where}curves must be a list of curve names (got {rc!r})")
    for c in rc:
        if curve_owner is not None and c not in curve_owner:
            known = ", ".join(sorted(curve_owner)) or "none"
            raise InputError(f"{where}curves: unknown curve '{c}' (known: {known})")
    rp = r.get("points", [])
    if not isinstance(rp, list):
        raise InputError(f"{where}points must be a list of points [x, y] (got {rp!r})")
    pts = np.array([_xy(p, f"{where}points[{k}]") for k, p in enumerate(rp)]).reshape(-1, 2)
    if not rc and not len(pts):
        raise InputError(f"{where[:-1]} needs curves = [...] and/or points = [[x, y], ...]")
    return Refine(curves=list(rc), points=pts, size=_number(r, "size", where),
                  distance=_number(r, "distance", where, strict=False),
                  flat=_number(r, "flat", where, strict=False, default=0.0))


def _patch(r: dict, where: str) -> Patch:
    """One [[mesh.patch]]: box = [xmin, ymin, xmax, ymax] with xmin < xmax, ymin < ymax."""
    for key in r:
        if key not in PATCH_KEYS:
            raise InputError(f"{where}{key} is not a patch key ({', '.join(PATCH_KEYS)})"
                             f"{suggestion(key, PATCH_KEYS)}")
    box = r.get("box")
    if not (isinstance(box, list) and len(box) == 4 and all(_is_number(v) for v in box)):
        raise InputError(f"{where}box must be [xmin, ymin, xmax, ymax] (got {box!r})")
    b = np.array(box, dtype=float)
    if not (b[0] < b[2] and b[1] < b[3]):
        raise InputError(f"{where}box = {box!r} needs xmin < xmax and ymin < ymax")
    return Patch(box=b, size=_number(r, "size", where))
