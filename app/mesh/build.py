"""Build the all-quadrilateral mesh of a scene with gmsh, one gmsh model per body.

Each body is meshed on its own (built-in geometry kernel) and the body meshes are
concatenated with node offsets, so bodies never share nodes and interface meshes are
non-matching in general. Unstructured bodies use Frontal-Delaunay for quads with blossom
full-quad recombination; `structured = true` rectangles use a transfinite grid.

Local refinement (`[[mesh.refine]]`) uses gmsh Distance + Threshold fields combined by a
Min field: the size is `size` within `flat` of the curves/points and grows linearly to
the body size over the next `distance`. Refinement points act on every body; refinement
curves act on the body owning them through the curve itself and on every other body
through a free copy of the curve geometry (not part of its surface, its nodes are dropped),
so both sides of a contact are refined. Structured bodies ignore refinement. Named
[points] lying on a body side become geometry vertices (so a node sits there); inside an
unstructured body they are embedded in the surface.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.mesh.cache import cache_key, cache_path, load_mesh, save_mesh
from app.mesh.geometry import Piece
from app.mesh.geometry import number as _number
from app.mesh.geometry import xy_point as _xy
from app.mesh.model import Mesh, orient_ccw
from app.mesh.shapes import SHAPES

REFINE_KEYS = ("curves", "points", "size", "distance", "flat")
POINT_TOL = 1e-6  # named points must lie within POINT_TOL * body size of a mesh node
MAX_BOUNDARY_ELEMENTS = 1e6  # a body's perimeter / element size at most this
_MAX_SAMPLING = 200_000  # cap on the sampling points of a Distance field curve
# Frontal-Delaunay (6): unlike 8, it follows the background size field inside the surface.
ALGORITHM = 5
RECOMBINATION = 3  # blossom full-quad: no triangle left
SMOOTHING = 5


# ----------------------------------------------------------------------------- geometry


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
class Scene:
    """Validated geometry part of a config."""

    size: float
    file: str | None
    bodies: list[BodySpec]
    refine: list[Refine]
    points: dict[str, np.ndarray]  # named points


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
    for key in shape:
        if key not in ("type", "structured", "divisions", *spec.keys):
            raise InputError(
                f"{w}{key} is not a key of a {kind} (keys: {', '.join(spec.keys)})"
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


def _split_at(pieces: list[Piece], xy: np.ndarray, tol: float) -> list[Piece]:
    out: list[Piece] = []
    for piece in pieces:
        t = piece.locate(xy, tol)
        out.extend(piece.split(t) if t is not None else [piece])
    return out


def parse_scene(cfg: dict, *, need_shapes: bool = True) -> Scene:
    """Validate the geometry part of a config ([mesh], [[body]], [points]).

    need_shapes: False when the mesh comes from a file (body shapes are then not used).
    Raises InputError naming the offending key.
    """
    mesh = _table(cfg.get("mesh"), "[mesh]") if "mesh" in cfg else None
    if mesh is None:
        raise InputError("[mesh] section is missing: it needs at least size = <element size>")
    file = mesh.get("file")
    if file is not None and (not isinstance(file, str) or not file):
        raise InputError(f"mesh.file must be a file name (got {file!r})")
    if file is not None and "size" not in mesh:
        size = math.nan
    else:
        size = _number(mesh, "size", "mesh.")

    named: dict[str, np.ndarray] = {}
    for name, v in _table(cfg.get("points", {}), "[points]").items():
        named[name] = _xy(v, f"points.{name}")

    bodies_cfg = cfg.get("body")
    if not isinstance(bodies_cfg, list) or not bodies_cfg:
        raise InputError("[[body]] is missing: the config needs at least one body")
    bodies: list[BodySpec] = []
    curve_owner: dict[str, str] = {}
    for i, b in enumerate(bodies_cfg):
        b = _table(b, f"body[{i}]")
        name = b.get("name")
        if not isinstance(name, str) or not name:
            raise InputError(f"body[{i}].name must be a non-empty string (got {name!r})")
        if any(x.name == name for x in bodies):
            raise InputError(f"body name '{name}' is used twice: body names must be unique")
        where = f"body '{name}': "
        bsize = _number(b, "size", where) if "size" in b else size
        if not need_shapes:
            bodies.append(BodySpec(name, bsize, {}, False, []))
            continue
        if "shape" not in b:
            raise InputError(f"{where}shape is missing: add a [body.shape] table with a type")
        shape = _table(b["shape"], f"{where}shape")
        raw_sides, structured = _shape_sides(shape, where)
        valid = [s for s, _ in raw_sides]
        curves = _table(b.get("curves", {}), f"{where}curves")
        for side, cname in curves.items():
            if side not in valid:
                raise InputError(
                    f"{where}curves.{side} is not a side of a {shape['type']} "
                    f"(sides: {', '.join(valid)})"
                )
            if not isinstance(cname, str) or not cname:
                raise InputError(f"{where}curves.{side} must be a curve name (got {cname!r})")
            owner = curve_owner.setdefault(cname, name)
            if owner != name:
                raise InputError(
                    f"curve name '{cname}' is used by bodies '{owner}' and '{name}': "
                    "each body needs its own curve names"
                )
        tol = POINT_TOL * bsize
        sides = []
        for sname, pieces in raw_sides:
            for xy in named.values():  # geometry vertex at every named point on a side
                pieces = _split_at(pieces, xy, tol)
            sides.append(Side(sname, curves.get(sname), pieces))
        spec = BodySpec(name, bsize, shape, structured, sides)
        if not structured:
            spec.interior_points = [xy for xy in named.values() if spec.contains(xy, tol)]
        bodies.append(spec)

    for pname in named:
        if pname in curve_owner:
            raise InputError(f"points.{pname}: the name is already used by a curve")

    refine: list[Refine] = []
    ref_cfg = mesh.get("refine", [])
    if not isinstance(ref_cfg, list):
        raise InputError("mesh.refine must be an array of tables [[mesh.refine]]")
    for i, r in enumerate(ref_cfg):
        where = f"mesh.refine[{i}]."
        r = _table(r, where[:-1])
        for key in r:
            if key not in REFINE_KEYS:
                raise InputError(f"{where}{key} is not a refinement key ({', '.join(REFINE_KEYS)})")
        rc = r.get("curves", [])
        if not isinstance(rc, list) or not all(isinstance(c, str) for c in rc):
            raise InputError(f"{where}curves must be a list of curve names (got {rc!r})")
        for c in rc:
            if need_shapes and c not in curve_owner:
                known = ", ".join(sorted(curve_owner)) or "none"
                raise InputError(f"{where}curves: unknown curve '{c}' (known: {known})")
        rp = r.get("points", [])
        if not isinstance(rp, list):
            raise InputError(f"{where}points must be a list of points [x, y] (got {rp!r})")
        pts = np.array([_xy(p, f"{where}points[{k}]") for k, p in enumerate(rp)]).reshape(-1, 2)
        if not rc and not len(pts):
            raise InputError(f"{where[:-1]} needs curves = [...] and/or points = [[x, y], ...]")
        refine.append(
            Refine(
                curves=list(rc),
                points=pts,
                size=_number(r, "size", where),
                distance=_number(r, "distance", where, strict=False),
                flat=_number(r, "flat", where, strict=False, default=0.0),
            )
        )
    return Scene(size, file, bodies, refine, named)


# ----------------------------------------------------------------------------- gmsh


@contextmanager
def _gmsh_session() -> Iterator[Any]:
    """Initialise gmsh (no display, no signal handler) unless already done; finalise after."""
    import gmsh

    started = not gmsh.isInitialized()
    if started:
        gmsh.initialize([], readConfigFiles=False, run=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        yield gmsh
    finally:
        if started:
            gmsh.finalize()


def _add_pieces(geo: Any, pieces: list[Piece], closed: bool) -> tuple[list[int], list[int]]:
    """Add consecutive pieces to the built-in kernel; return their curve and start point tags."""
    starts = [geo.addPoint(p.p0[0], p.p0[1], 0.0) for p in pieces]
    if not closed:
        starts.append(geo.addPoint(pieces[-1].p1[0], pieces[-1].p1[1], 0.0))
    tags = []
    for i, p in enumerate(pieces):
        a, b = starts[i], starts[(i + 1) % len(starts)]
        if p.kind == "line":
            tags.append(geo.addLine(a, b))
        else:
            c = geo.addPoint(p.center[0], p.center[1], 0.0)
            tags.append(geo.addCircleArc(a, c, b))
    return tags, starts


def _intervals(lengths: list[float], n: int) -> list[int]:
    """Split n intervals over pieces in proportion to their lengths (each >= 1)."""
    cum = np.cumsum(lengths) / np.sum(lengths)
    b = [int(math.floor(c * n + 0.5)) for c in cum]
    b[-1] = n
    for k in range(len(b)):
        b[k] = max(b[k], (b[k - 1] if k else 0) + 1)
    for k in range(len(b) - 2, -1, -1):
        b[k] = min(b[k], b[k + 1] - 1)
    return list(np.diff([0, *b]))


def _mesh_body(gmsh: Any, spec: BodySpec, scene: Scene, scale: float) -> tuple:
    """Mesh one body in its own gmsh model.

    Returns points (n, 2), quads (ne, 4) counter-clockwise and curves name -> (m, 2),
    all with body-local node indices.
    """
    h = spec.size * scale
    gmsh.model.add(f"body:{spec.name}")
    try:
        geo = gmsh.model.geo
        pieces = [p for s in spec.sides for p in s.pieces]
        perimeter = sum(p.length for p in pieces)
        if not (math.isfinite(perimeter) and perimeter / h <= MAX_BOUNDARY_ELEMENTS):
            raise InputError(
                f"body '{spec.name}': its boundary ({perimeter:.3g}) over the element size "
                f"({h:.3g}) would need more than {MAX_BOUNDARY_ELEMENTS:.0e} boundary "
                "elements: check the body's dimensions and mesh.size / body size"
            )
        tags, ptags = _add_pieces(geo, pieces, closed=True)
        side_tags, k = [], 0
        for s in spec.sides:
            side_tags.append(tags[k : k + len(s.pieces)])
            k += len(s.pieces)
        surf = geo.addPlaneSurface([geo.addCurveLoop(tags)])

        if spec.structured:
            width = sum(p.length for p in spec.sides[0].pieces)
            height = sum(p.length for p in spec.sides[1].pieces)
            npieces = [len(s.pieces) for s in spec.sides]
            if "divisions" in spec.shape:  # element counts, refined with the scale
                fx, fy = (max(1, int(math.floor(k / scale + 0.5)))
                          for k in spec.shape["divisions"])
            else:
                fx = int(math.floor(width / h + 0.5))
                fy = int(math.floor(height / h + 0.5))
            nx = max(1, fx, npieces[0], npieces[2])
            ny = max(1, fy, npieces[1], npieces[3])
            for s, st, n in zip(spec.sides, side_tags, (nx, ny, nx, ny), strict=True):
                for tag, m in zip(st, _intervals([p.length for p in s.pieces], n), strict=True):
                    geo.mesh.setTransfiniteCurve(tag, int(m) + 1)
            corners = [ptags[k] for k in np.cumsum([0, *npieces[:3]])]
            geo.synchronize()
            gmsh.model.mesh.setTransfiniteSurface(surf, "Left", corners)
            gmsh.model.mesh.setRecombine(2, surf)
        else:
            embed = [geo.addPoint(p[0], p[1], 0.0) for p in spec.interior_points]
            fields = _add_refinement(geo, spec, scene, side_tags, scale)
            geo.synchronize()
            if embed:
                gmsh.model.mesh.embed(0, embed, 2, surf)
            fm = gmsh.model.mesh.field
            thresholds = []
            for r, rpoints, ctags, sampling in fields:
                d = fm.add("Distance")
                if rpoints:
                    fm.setNumbers(d, "PointsList", rpoints)
                if ctags:
                    fm.setNumbers(d, "CurvesList", ctags)
                    fm.setNumber(d, "Sampling", sampling)
                t = fm.add("Threshold")
                fm.setNumber(t, "InField", d)
                fm.setNumber(t, "SizeMin", r.size * scale)
                fm.setNumber(t, "SizeMax", h)
                fm.setNumber(t, "DistMin", r.flat)
                fm.setNumber(t, "DistMax", r.flat + max(r.distance, 1e-9 * spec.size))
                thresholds.append(t)
            if thresholds:
                m = fm.add("Min")
                fm.setNumbers(m, "FieldsList", thresholds)
                fm.setAsBackgroundMesh(m)

        opt = gmsh.option.setNumber
        opt("Mesh.Algorithm", ALGORITHM)
        opt("Mesh.RecombineAll", 1)
        opt("Mesh.RecombinationAlgorithm", RECOMBINATION)
        opt("Mesh.Smoothing", SMOOTHING)
        opt("Mesh.SubdivisionAlgorithm", 0)
        opt("Mesh.ElementOrder", 1)
        opt("Mesh.MeshSizeFromPoints", 0)
        opt("Mesh.MeshSizeFromCurvature", 0)
        opt("Mesh.MeshSizeExtendFromBoundary", 0)
        opt("Mesh.MeshSizeMin", 0.0)
        opt("Mesh.MeshSizeMax", h)
        try:
            gmsh.model.mesh.generate(2)
        except Exception as e:  # gmsh raises a bare Exception with its last error
            raise InputError(f"body '{spec.name}': gmsh could not mesh it: {e}") from None
        return _extract(gmsh, spec, surf, side_tags)
    finally:
        gmsh.model.remove()


def _add_refinement(geo: Any, spec: BodySpec, scene: Scene, side_tags: list[list[int]],
                    scale: float) -> list[tuple[Refine, list[int], list[int], int]]:
    """Geometry for the refinement fields of one body: (refine, point tags, curve tags,
    sampling) per `[[mesh.refine]]` entry. Curves of other bodies become free copies."""
    own = {}
    for s, st in zip(spec.sides, side_tags, strict=True):
        if s.curve is not None:
            own.setdefault(s.curve, []).extend(zip(st, s.pieces, strict=True))
    out = []
    for r in scene.refine:
        ptags = [geo.addPoint(x, y, 0.0) for x, y in r.points]
        ctags: list[int] = []
        lengths: list[float] = []
        for c in r.curves:
            if c in own:
                ctags.extend(t for t, _ in own[c])
                lengths.extend(p.length for _, p in own[c])
                continue
            for other in scene.bodies:
                pieces = other.curve_pieces(c)
                if pieces and other is not spec:
                    for p in pieces:  # one by one: a curve's pieces need not be contiguous
                        ctags.extend(_add_pieces(geo, [p], closed=False)[0])
                    lengths.extend(p.length for p in pieces)
        spacing = 0.5 * r.size * scale
        sampling = min(_MAX_SAMPLING, max(20, math.ceil(max(lengths, default=0) / spacing) + 1))
        out.append((r, ptags, ctags, sampling))
    return out


def _extract(gmsh: Any, spec: BodySpec, surf: int, side_tags: list[list[int]]) -> tuple:
    """Quads, used nodes and named curve edges of the current model, renumbered 0..n-1."""
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    ntags = np.asarray(ntags, dtype=np.int64)
    xy = np.asarray(coords).reshape(-1, 3)[:, :2]
    types, _, enodes = gmsh.model.mesh.getElements(2, surf)
    types = [int(t) for t in types]
    if any(t != 3 for t in types):
        n_other = sum(len(e) for t, e in zip(types, enodes, strict=True) if t != 3) // 3
        raise InputError(
            f"body '{spec.name}': gmsh left {n_other} non-quadrilateral elements; "
            "try another element size"
        )
    q = np.asarray(enodes[types.index(3)], dtype=np.int64).reshape(-1, 4)
    top = int(ntags.max()) + 1
    row = np.empty(top, dtype=np.int64)
    row[ntags] = np.arange(len(ntags))
    used = np.zeros(top, dtype=bool)
    used[q.ravel()] = True
    used_tags = np.flatnonzero(used)
    local = np.full(top, -1, dtype=np.int64)
    local[used_tags] = np.arange(len(used_tags))
    points = xy[row[used_tags]]
    quads = orient_ccw(points, local[q])

    curves: dict[str, list[np.ndarray]] = {}
    for s, st in zip(spec.sides, side_tags, strict=True):
        if s.curve is None:
            continue
        for tag in st:
            lt, _, ln = gmsh.model.mesh.getElements(1, tag)
            for t, nodes in zip(lt, ln, strict=True):
                if int(t) == 1:
                    curves.setdefault(s.curve, []).append(
                        local[np.asarray(nodes, dtype=np.int64).reshape(-1, 2)]
                    )
    return points, quads, {k: np.concatenate(v) for k, v in curves.items()}


# ----------------------------------------------------------------------------- public


def attach_named_points(mesh: Mesh, named: dict[str, np.ndarray], sizes: list[float]) -> None:
    """Add a point group per named point: the node within POINT_TOL * body size of it.

    sizes: element size per body (config units), for the tolerance.
    """
    nb = mesh.node_body()
    for name, xy in named.items():
        if name in mesh.point_groups or name in mesh.curves:
            raise InputError(f"points.{name}: the mesh already has a group named '{name}'")
        d = np.hypot(mesh.points[:, 0] - xy[0], mesh.points[:, 1] - xy[1])
        d[nb < 0] = np.inf
        i = int(np.argmin(d))
        tol = POINT_TOL * sizes[nb[i]] if np.isfinite(d[i]) else 0.0
        if not d[i] <= tol:
            raise InputError(
                f"points.{name} = [{xy[0]:g}, {xy[1]:g}] is {d[i]:.3g} away from the nearest "
                "mesh node: put the point on a body side or corner"
            )
        mesh.point_groups[name] = np.array([i], dtype=np.int64)


def build_mesh(cfg: dict, scale: float = 1.0, cache_dir: str | Path | None = None, *,
               base_dir: str | Path | None = None) -> Mesh:
    """Mesh every body of a parsed config (TOML dict) and concatenate them into one Mesh.

    scale: multiplies every element size (mesh.size, body sizes, refinement sizes).
    cache_dir: if given, reuse/store the mesh as .npz keyed by a hash of the body shapes,
        the [mesh] and [points] sections, `scale` and the gmsh version.
    base_dir: directory that a relative mesh.file is relative to (default: working dir).
    With mesh.file set, that gmsh .msh is read instead (scale and cache_dir are unused).
    """
    mesh_cfg = cfg.get("mesh")
    if isinstance(mesh_cfg, dict) and mesh_cfg.get("file") is not None:
        from app.mesh.read import read_mesh

        scene = parse_scene(cfg, need_shapes=False)
        path = Path(scene.file)
        if base_dir is not None and not path.is_absolute():
            path = Path(base_dir) / path
        mesh = read_mesh(path, [b.name for b in scene.bodies])
        span = float(np.ptp(mesh.points, axis=0).max()) if mesh.n_nodes else 1.0
        sizes = [b.size if math.isfinite(b.size) else span for b in scene.bodies]
        attach_named_points(mesh, scene.points, sizes)
        return mesh

    if isinstance(scale, bool) or not isinstance(scale, int | float | np.floating):
        raise InputError(f"mesh size scale must be a number > 0 (got {scale!r})")
    scale = float(scale)
    if not (math.isfinite(scale) and scale > 0):
        raise InputError(f"mesh size scale must be a number > 0 (got {scale!r})")
    scene = parse_scene(cfg)
    import gmsh

    cache_file = None
    if cache_dir is not None:
        payload = {
            "bodies": [
                {k: b.get(k) for k in ("name", "shape", "size", "curves")} for b in cfg["body"]
            ],
            "mesh": cfg["mesh"],
            "points": cfg.get("points", {}),
            "scale": scale,
            "gmsh": gmsh.__version__,
        }
        cache_file = cache_path(cache_dir, cache_key(payload))
        cached = load_mesh(cache_file)
        if cached is not None:
            return cached

    parts = []
    with _gmsh_session() as g:
        for spec in scene.bodies:
            parts.append(_mesh_body(g, spec, scene, scale))

    offsets = np.cumsum([0] + [len(p[0]) for p in parts])
    curves: dict[str, np.ndarray] = {}
    for (_, _, cv), off in zip(parts, offsets, strict=False):
        for name, edges in cv.items():
            curves[name] = edges + off
    mesh = Mesh(
        points=np.concatenate([p[0] for p in parts]),
        quads=np.concatenate([p[1] + off for p, off in zip(parts, offsets, strict=False)]),
        body=np.concatenate(
            [np.full(len(p[1]), i, dtype=np.int64) for i, p in enumerate(parts)]
        ),
        body_names=[b.name for b in scene.bodies],
        curves=curves,
    )
    attach_named_points(mesh, scene.points, [b.size for b in scene.bodies])
    if cache_file is not None:
        save_mesh(cache_file, mesh)
    return mesh
