"""Build the all-quadrilateral mesh of a scene with gmsh, one gmsh model per body.

Each body is meshed on its own (built-in geometry kernel) and the body meshes are
concatenated with node offsets, so bodies never share nodes and interface meshes are
non-matching in general. Unstructured bodies use the gmsh recipe named by `mesh.algorithm`
(app/scene/mesh_algorithms.py; default Delaunay with blossom full-quad recombination);
`structured = true` rectangles use a transfinite grid.

Local refinement (`[[mesh.refine]]`) uses gmsh Distance + Threshold fields combined by a
Min field: the size is `size` within `flat` of the curves/points and grows linearly to
the body size over the next `distance`. Refinement points act on every body; refinement
curves act on the body owning them through the curve itself and on every other body
through a free copy of the curve geometry (not part of its surface, its nodes are dropped),
so both sides of a contact are refined. Structured bodies ignore refinement. Named
[points] lying on a body side become geometry vertices (so a node sits there); inside an
unstructured body they are embedded in the surface.

Structured contact patches (`[[mesh.patch]]`, app/mesh/patch.py): an unstructured body
that a patch box meets is built with the OpenCASCADE kernel instead, cut by the boxes,
and its pieces inside them meshed as transfinite grids; named sides are found again
after the cut, so every named curve keeps all its pieces.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from app.errors import InputError
from app.mesh.cache import cache_key, cache_path, load_mesh, save_mesh
from app.mesh.model import Mesh, orient_ccw
from app.mesh.near_points import near_point_fields
from app.mesh.patch import apply as patch_apply
from app.mesh.patch import cut as patch_cut
from app.mesh.patch import patches_meeting
from app.mesh.short_curves import generate_quads
from app.scene import BodySpec, Refine, Scene
from app.scene.geometry import Piece
from app.scene.mesh_algorithms import gmsh_options
from app.scene.parse import POINT_TOL

MAX_BOUNDARY_ELEMENTS = 1e6  # a body's perimeter / element size at most this
_MAX_SAMPLING = 200_000  # cap on the sampling points of a Distance field curve


# ----------------------------------------------------------------------------- gmsh


@contextmanager
def _gmsh_session() -> Iterator[Any]:
    """Initialise gmsh (no display, no signal handler) unless already done; finalise after."""
    import gmsh

    started = not gmsh.isInitialized()
    handlers = _python_signal_handlers()
    if started:
        gmsh.initialize([], readConfigFiles=False, run=False, interruptible=False)
        _restore_signal_handlers(handlers)  # gmsh.initialize resets them to the defaults
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        yield gmsh
    finally:
        if started:
            gmsh.finalize()
            _restore_signal_handlers(handlers)


def _python_signal_handlers() -> dict:
    """The Python-level SIGINT and SIGTERM handlers (a run's stop handlers) and SIGPIPE's
    (ignored, as Python has it: gmsh's default ended the process silently on a write to a
    closed pipe, e.g. rank 0 writing into a HiGHS process that mpiexec's SIGTERM had just
    killed, before its watchdog wrote `interrupted`: tests/test_stop_sigpipe.py)."""
    import signal

    names = ("SIGINT", "SIGTERM", "SIGPIPE")
    return {sig: signal.getsignal(sig) for n in names if (sig := getattr(signal, n, None))}


def _restore_signal_handlers(handlers: dict) -> None:
    """Install the handlers again at the C level (gmsh replaced them with the defaults)."""
    import signal

    for sig, handler in handlers.items():
        if handler is not None:  # (None: not installed from Python)
            try:
                signal.signal(sig, handler)
            except ValueError:  # not the main thread
                return


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


def _check_boundary_count(spec: BodySpec, h: float) -> None:
    """InputError if the body's boundary over the element size h is absurdly many elements."""
    perimeter = sum(p.length for s in spec.sides for p in s.pieces)
    if not (math.isfinite(perimeter) and perimeter / h <= MAX_BOUNDARY_ELEMENTS):
        raise InputError(
            f"body '{spec.name}': its boundary ({perimeter:.3g}) over the element size "
            f"({h:.3g}) would need more than {MAX_BOUNDARY_ELEMENTS:.0e} boundary "
            "elements: check the body's dimensions and mesh.size / body size"
        )


def _set_structured(gmsh: Any, geo: Any, spec: BodySpec, surf: int, side_tags: list,
                    ptags: list, h: float, scale: float) -> None:
    """Transfinite quads on a four-sided body: counts from `divisions` or the size h."""
    width = sum(p.length for p in spec.sides[0].pieces)
    height = sum(p.length for p in spec.sides[1].pieces)
    npieces = [len(s.pieces) for s in spec.sides]
    if "divisions" in spec.shape:  # element counts, refined with the scale
        fx, fy = (max(1, int(math.floor(k / scale + 0.5))) for k in spec.shape["divisions"])
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


def _set_size_fields(gmsh: Any, fields: list, h: float, scale: float, size: float) -> None:
    """One Distance + Threshold field per refinement, their Min as the background size."""
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
        fm.setNumber(t, "DistMax", r.flat + max(r.distance, 1e-9 * size))
        thresholds.append(t)
    if thresholds:
        m = fm.add("Min")
        fm.setNumbers(m, "FieldsList", thresholds)
        fm.setAsBackgroundMesh(m)


def _generate(gmsh: Any, spec: BodySpec, scene: Scene, h: float) -> None:
    """Quad meshing options (the algorithm recipe last), then gmsh's 2D mesh."""
    opt = gmsh.option.setNumber
    opt("Mesh.RecombineAll", 1)
    opt("Mesh.SubdivisionAlgorithm", 0)
    opt("Mesh.ElementOrder", 1)
    opt("Mesh.MeshSizeFromPoints", 0)
    opt("Mesh.MeshSizeFromCurvature", 0)
    opt("Mesh.MeshSizeExtendFromBoundary", 0)
    opt("Mesh.MeshSizeMin", 0.0)
    opt("Mesh.MeshSizeMax", h)
    for key, value in gmsh_options(scene.algorithm).items():  # after: a recipe may
        opt(key, value)  # override the options above
    try:
        generate_quads(gmsh)  # with a retry for curves shorter than the element size
    except Exception as e:  # gmsh raises a bare Exception with its last error
        raise InputError(f"body '{spec.name}': gmsh could not mesh it: {e}") from None


def _mesh_body(gmsh: Any, spec: BodySpec, scene: Scene, scale: float) -> tuple:
    """Mesh one body in its own gmsh model.

    Returns points (n, 2), quads (ne, 4) counter-clockwise and curves name -> (m, 2),
    all with body-local node indices.
    """
    h = spec.size * scale
    gmsh.model.add(f"body:{spec.name}")
    meeting = [] if spec.structured else patches_meeting(spec, scene.patches)
    try:
        geo = gmsh.model.occ if meeting else gmsh.model.geo  # OCC: boxes cut the surface
        _check_boundary_count(spec, h)
        tags, ptags = _add_pieces(geo, [p for s in spec.sides for p in s.pieces], closed=True)
        side_tags, k = [], 0
        for s in spec.sides:
            side_tags.append(tags[k : k + len(s.pieces)])
            k += len(s.pieces)
        surf = geo.addPlaneSurface([geo.addCurveLoop(tags)])
        surfs, plans = [surf], []
        if meeting:
            surfs, side_tags, plans = patch_cut(gmsh, spec, surf, meeting, scale)
        if spec.structured:
            _set_structured(gmsh, geo, spec, surf, side_tags, ptags, h, scale)
        else:
            embed = [geo.addPoint(p[0], p[1], 0.0) for p in spec.interior_points]
            fields = _add_refinement(geo, spec, scene, side_tags, scale)
            fields += [(r, [embed[k]], [], 0) for k, r in near_point_fields(spec, h, scale)]
            geo.synchronize()
            patch_apply(gmsh, plans)
            for tag, xy in zip(embed, spec.interior_points, strict=True):
                gmsh.model.mesh.embed(0, [tag], 2, _surface_at(gmsh, surfs, plans, xy, spec))
            _set_size_fields(gmsh, fields, h, scale, spec.size)
        _generate(gmsh, spec, scene, h)
        return _extract(gmsh, spec, surfs, side_tags)
    finally:
        gmsh.model.remove()


def _add_refinement(geo: Any, spec: BodySpec, scene: Scene, side_tags: list[list[int]],
                    scale: float) -> list[tuple[Refine, list[int], list[int], int]]:
    """Geometry for the refinement fields of one body: (refine, point tags, curve tags,
    sampling) per `[[mesh.refine]]` entry. Curves of other bodies become free copies."""
    own: dict[str, tuple[list[int], list[Piece]]] = {}
    for s, st in zip(spec.sides, side_tags, strict=True):  # st: s.pieces, or cut pieces
        if s.curve is not None:
            tags_, pieces_ = own.setdefault(s.curve, ([], []))
            tags_.extend(st)
            pieces_.extend(s.pieces)
    out = []
    for r in scene.refine:
        ptags = [geo.addPoint(x, y, 0.0) for x, y in r.points]
        ctags: list[int] = []
        lengths: list[float] = []
        for c in r.curves:
            if c in own:
                ctags.extend(own[c][0])
                lengths.extend(p.length for p in own[c][1])
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


def _surface_at(gmsh: Any, surfs: list[int], plans: list, xy: np.ndarray,
                spec: BodySpec) -> int:
    """The surface holding an interior point to embed (not a structured patch piece)."""
    if len(surfs) == 1:
        return surfs[0]
    structured = {p.surface for p in plans}
    for s in surfs:
        if gmsh.model.isInside(2, s, [xy[0], xy[1], 0.0]):
            if s in structured:
                raise InputError(f"body '{spec.name}': the named point [{xy[0]:g}, "
                                 f"{xy[1]:g}] lies inside a [[mesh.patch]] box: put it on "
                                 "the body's side or outside the box")
            return s
    return surfs[0]


def _extract(gmsh: Any, spec: BodySpec, surfs: list[int],
             side_tags: list[list[int]]) -> tuple:
    """Quads, used nodes and named curve edges of the current model, renumbered 0..n-1."""
    ntags, coords, _ = gmsh.model.mesh.getNodes()
    ntags = np.asarray(ntags, dtype=np.int64)
    xy = np.asarray(coords).reshape(-1, 3)[:, :2]
    blocks = []
    for surf in surfs:
        types, _, enodes = gmsh.model.mesh.getElements(2, surf)
        types = [int(t) for t in types]
        if any(t != 3 for t in types):
            n_other = sum(len(e) for t, e in zip(types, enodes, strict=True) if t != 3) // 3
            raise InputError(
                f"body '{spec.name}': gmsh left {n_other} non-quadrilateral elements; "
                "try another element size"
            )
        blocks.append(np.asarray(enodes[types.index(3)], dtype=np.int64).reshape(-1, 4))
    q = np.concatenate(blocks)
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


def build_mesh(scene: Scene, scale: float = 1.0, cache_dir: str | Path | None = None, *,
               base_dir: str | Path | None = None) -> Mesh:
    """Mesh every body of a scene (`app.scene.parse_scene`) into one Mesh.

    scale: multiplies every element size (mesh.size, body sizes, refinement sizes).
    cache_dir: if given, reuse/store the mesh as .npz keyed by a hash of the body shapes,
        the [mesh] and [points] sections, `scale` and the gmsh version.
    base_dir: directory that a relative mesh.file is relative to (default: working dir).
    With mesh.file set, that gmsh .msh is read instead (scale and cache_dir are unused).
    """
    if scene.file is not None:
        return _read_scene_file(scene, base_dir)
    scale = _checked_scale(scale)
    import gmsh

    cache_file = None
    if cache_dir is not None:
        payload = scene.source | {"scale": scale, "gmsh": gmsh.__version__,
                                  "algorithm": scene.algorithm}
        if any(spec.interior_points for spec in scene.bodies):  # (meshed otherwise before
            payload["near_points"] = 1  # app/mesh/near_points.py; other keys unchanged)
        cache_file = cache_path(cache_dir, cache_key(payload))
        cached = load_mesh(cache_file)
        if cached is not None:
            return cached

    parts = []
    with _gmsh_session() as g:
        for spec in scene.bodies:
            parts.append(_mesh_body(g, spec, scene, scale))
    mesh = _join_bodies(parts, [b.name for b in scene.bodies])
    attach_named_points(mesh, scene.points, [b.size for b in scene.bodies])
    if cache_file is not None:
        save_mesh(cache_file, mesh)
    return mesh


def _read_scene_file(scene: Scene, base_dir: str | Path | None) -> Mesh:
    """The gmsh .msh of mesh.file (relative to base_dir if given) with the named points
    attached; a body without a size uses the mesh's extent as its point tolerance scale."""
    from app.mesh.read import read_mesh

    path = Path(scene.file)
    if base_dir is not None and not path.is_absolute():
        path = Path(base_dir) / path
    mesh = read_mesh(path, [b.name for b in scene.bodies])
    span = float(np.ptp(mesh.points, axis=0).max()) if mesh.n_nodes else 1.0
    sizes = [b.size if math.isfinite(b.size) else span for b in scene.bodies]
    attach_named_points(mesh, scene.points, sizes)
    return mesh


def _checked_scale(scale: Any) -> float:
    """The mesh size scale as a float; InputError unless a finite number > 0."""
    if isinstance(scale, bool) or not isinstance(scale, int | float | np.floating):
        raise InputError(f"mesh size scale must be a number > 0 (got {scale!r})")
    scale = float(scale)
    if not (math.isfinite(scale) and scale > 0):
        raise InputError(f"mesh size scale must be a number > 0 (got {scale!r})")
    return scale


def _join_bodies(parts: list[tuple], names: list[str]) -> Mesh:
    """One Mesh of the per-body (points, quads, curves) of `_mesh_body`, in body order:
    node numbers (in quads and curves) offset by the nodes of the bodies before."""
    offsets = np.cumsum([0] + [len(p[0]) for p in parts])
    curves: dict[str, np.ndarray] = {}
    for (_, _, cv), off in zip(parts, offsets, strict=False):
        for name, edges in cv.items():
            curves[name] = edges + off
    return Mesh(
        points=np.concatenate([p[0] for p in parts]),
        quads=np.concatenate([p[1] + off for p, off in zip(parts, offsets, strict=False)]),
        body=np.concatenate(
            [np.full(len(p[1]), i, dtype=np.int64) for i, p in enumerate(parts)]
        ),
        body_names=names,
        curves=curves,
    )
