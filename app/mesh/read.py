"""Read a ready gmsh .msh file (MSH 2.2 or 4.1) with meshio into a `Mesh`.

Physical surfaces are bodies (matched by name to the config's [[body]] names), physical
curves (line elements) are named curves and physical points are point groups. Only
linear quadrilaterals are accepted. Unused nodes are dropped, nodes renumbered in body
order and quads oriented counter-clockwise.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.errors import InputError
from app.mesh.coincident import check_coincident_nodes
from app.mesh.model import Mesh, orient_ccw
from app.user_paths import path_kind

_KINDS = {"vertex": 0, "line": 1, "quad": 2}  # accepted cell types -> dimension
_DIM_WORD = {0: "point", 1: "curve", 2: "surface"}
_IGNORED_1D = ("line3", "line4", "line5")


def _other_cell_error(fname: str, kind: str, n: int) -> InputError:
    if kind.startswith("triangle"):
        return InputError(
            f"mesh file {fname} has {n} triangles: only quadrilaterals are supported"
        )
    if kind.startswith(("quad", "polygon")):
        return InputError(
            f"mesh file {fname} has {n} {kind} elements: only linear quadrilaterals "
            "(4 nodes) are supported"
        )
    return InputError(
        f"mesh file {fname} has {n} {kind} elements: only 2D quadrilateral meshes are supported"
    )


def _groups(m, fname: str) -> dict[tuple[int, str], list[tuple[int, np.ndarray]]]:
    """(dim, name) -> [(cell block index, cell indices)] of every physical group."""
    named = {(int(v[1]), int(v[0])): k for k, v in (m.field_data or {}).items() if len(v) >= 2}
    out: dict[tuple[int, str], list[tuple[int, np.ndarray]]] = {}
    phys = (m.cell_data or {}).get("gmsh:physical")
    # Unnamed physical groups are an error (every group must be named).
    if phys is not None:
        for blk, tags in zip(m.cells, phys, strict=True):
            if blk.type not in _KINDS:
                continue
            dim = _KINDS[blk.type]
            for tag in np.unique(tags):
                if tag != 0 and (dim, int(tag)) not in named:
                    raise InputError(
                        f"mesh file {fname}: physical {_DIM_WORD[dim]} {int(tag)} has no name: "
                        "name every physical group"
                    )
    sets = m.cell_sets or {}
    if any(name in sets for name in named.values()):  # MSH 4: exact per-group cell sets
        for (dim, _), name in named.items():
            for b, idx in enumerate(sets.get(name, [])):
                blk = m.cells[b]
                if idx is not None and len(idx) and _KINDS.get(blk.type) == dim:
                    out.setdefault((dim, name), []).append((b, np.asarray(idx, np.int64)))
    elif phys is not None:  # MSH 2: one physical tag per (duplicated) element
        for b, (blk, tags) in enumerate(zip(m.cells, phys, strict=True)):
            if blk.type not in _KINDS:
                continue
            dim = _KINDS[blk.type]
            tags = np.asarray(tags)
            for tag in np.unique(tags):
                if tag != 0:
                    out.setdefault((dim, named[(dim, int(tag))]), []).append(
                        (b, np.flatnonzero(tags == tag))
                    )
    return out


def _load_msh(path: Path):
    """meshio's mesh of a .msh file whose cells are all accepted kinds; InputError if not."""
    import meshio.gmsh

    fname = str(path)
    kind = path_kind(path, "mesh file (mesh.file)")
    if kind != "file":
        raise InputError(f"mesh file {fname} " + ("not found" if kind is None else
                                                  "is not a file") + " (mesh.file)")
    try:
        m = meshio.gmsh.read(path)  # not meshio.read: that one calls sys.exit on failure
    except Exception as e:  # meshio raises assorted exception types on bad input
        msg = str(e).splitlines()[0] if str(e).strip() else type(e).__name__
        raise InputError(f"mesh file {fname} is not a readable gmsh .msh file: {msg}") from None
    counts: dict[str, int] = {}
    for blk in m.cells:
        counts[blk.type] = counts.get(blk.type, 0) + len(blk.data)
    for kind, n in sorted(counts.items(), key=lambda kn: not kn[0].startswith("triangle")):
        if kind not in _KINDS and kind not in _IGNORED_1D:
            raise _other_cell_error(fname, kind, n)
    return m


def _planar_points(m, fname: str) -> np.ndarray:
    """(n, 2) node coordinates; InputError unless every z is 0."""
    pts = np.asarray(m.points, dtype=float)
    if pts.shape[1] > 2 and np.any(np.abs(pts[:, 2]) > 1e-12 * max(1.0, np.abs(pts).max())):
        raise InputError(f"mesh file {fname} is not planar: every node needs z = 0")
    return pts[:, :2]


def _check_surfaces(surfaces: dict, body_names: list[str], fname: str) -> None:
    """Every physical surface is a body and every body has one."""
    for name in surfaces:
        if name not in body_names:
            raise InputError(
                f"mesh file {fname}: physical surface '{name}' is not a [[body]] name "
                f"(bodies: {', '.join(body_names)})"
            )
    for name in body_names:
        if name not in surfaces:
            raise InputError(f"mesh file {fname} has no physical surface for body '{name}'")


def _body_quads(m, surfaces: dict, body_names: list[str], fname: str) -> list[np.ndarray]:
    """(n_b, 4) raw node ids of each body's quads; every quad in exactly one body."""
    n_quads = sum(len(blk.data) for blk in m.cells if blk.type == "quad")
    parts = [
        np.concatenate([m.cells[b].data[idx] for b, idx in surfaces[name]]).astype(np.int64)
        for name in body_names
    ]
    if sum(len(q) for q in parts) != n_quads:
        raise InputError(
            f"mesh file {fname}: {abs(n_quads - sum(len(q) for q in parts))} quadrilaterals "
            "are in no or in several physical surfaces: put each in exactly one body surface"
        )
    return [_distinct_quads(q) for q in parts]


def _distinct_quads(q: np.ndarray) -> np.ndarray:
    """Each quad (n, 4) once, in the order given: MSH 2.2 repeats the elements of a surface
    listed twice in its physical group, and the body had twice its stiffness."""
    s = np.sort(q, axis=1)
    n = int(s.max(initial=0)) + 1
    k1, k2 = s[:, 0] * n + s[:, 1], s[:, 2] * n + s[:, 3]
    order = np.lexsort((k2, k1))  # stable: the first of equal quads comes first
    dup = (k1[order][1:] == k1[order][:-1]) & (k2[order][1:] == k2[order][:-1])
    keep = np.ones(len(q), dtype=bool)
    keep[order[1:][dup]] = False
    return q[keep]


def _node_owner(n_points: int, parts: list[np.ndarray], body_names: list[str], fname: str):
    """(n_points,) body index of every node (-1: unused); InputError if bodies share nodes."""
    owner = np.full(n_points, -1, dtype=np.int64)
    for i, q in enumerate(parts):
        nodes = np.unique(q)
        taken = owner[nodes] >= 0
        if np.any(taken):
            other = body_names[int(owner[nodes[taken][0]])]
            raise InputError(
                f"mesh file {fname}: bodies '{other}' and '{body_names[i]}' share nodes: "
                "mesh each body separately so that bodies have their own nodes"
            )
        owner[nodes] = i
    return owner


def _lower_groups(m, groups: dict, new: np.ndarray, fname: str):
    """Named curves ((k, 2) segments) and point groups in the new node numbering."""
    curves: dict[str, np.ndarray] = {}
    point_groups: dict[str, np.ndarray] = {}
    for (dim, name), parts in groups.items():
        if dim == 2:
            continue
        raw = np.concatenate([m.cells[b].data[idx] for b, idx in parts]).astype(np.int64)
        ids = new[raw]
        if np.any(ids < 0):
            raise InputError(
                f"mesh file {fname}: physical {_DIM_WORD[dim]} '{name}' has nodes on no "
                "quadrilateral of a body"
            )
        if dim == 1:
            curves[name] = _distinct_edges(ids.reshape(-1, 2))
        else:
            point_groups[name] = np.unique(ids.ravel())
    for name in point_groups:
        if name in curves:
            raise InputError(
                f"mesh file {fname}: '{name}' is both a physical curve and a physical point"
            )
    return curves, point_groups


def _distinct_edges(edges: np.ndarray) -> np.ndarray:
    """Each edge (k, 2) once, in its first direction, in the order given: MSH 2.2 repeats
    the elements of a curve listed twice in its physical group (gmsh's
    addPhysicalGroup(1, [c, c])), and a load on the curve counted them twice."""
    lo, hi = np.minimum(edges[:, 0], edges[:, 1]), np.maximum(edges[:, 0], edges[:, 1])
    _, first = np.unique(lo * (int(edges.max(initial=0)) + 1) + hi, return_index=True)
    return edges[np.sort(first)]


def read_mesh(path: str | Path, body_names: list[str]) -> Mesh:
    """Read a gmsh .msh file of linear quadrilaterals into a Mesh.

    path: the .msh file. body_names: the config's [[body]] names; every physical surface
    must be one of them and every body needs one. Raises InputError (one line) naming the
    file and the group or element type to fix.
    """
    path = Path(path)
    fname = str(path)
    m = _load_msh(path)
    xy = _planar_points(m, fname)
    groups = _groups(m, fname)
    surfaces = {name: v for (dim, name), v in groups.items() if dim == 2}
    _check_surfaces(surfaces, body_names, fname)
    parts = _body_quads(m, surfaces, body_names, fname)
    quads = np.concatenate(parts) if parts else np.zeros((0, 4), np.int64)
    body = np.repeat(np.arange(len(parts), dtype=np.int64), [len(q) for q in parts])
    owner = _node_owner(len(xy), parts, body_names, fname)
    # Drop unused nodes; number nodes in order of first use by body.
    used = np.flatnonzero(owner >= 0)
    order = used[np.argsort(owner[used], kind="stable")]
    new = np.full(len(xy), -1, dtype=np.int64)
    new[order] = np.arange(len(order))
    points = xy[order].copy()
    quads = orient_ccw(points, new[quads])
    check_coincident_nodes(points, quads, body, list(body_names), fname)
    curves, point_groups = _lower_groups(m, groups, new, fname)
    return Mesh(points, quads, body, list(body_names), curves, point_groups,
                dropped_nodes=xy[owner < 0].copy())
