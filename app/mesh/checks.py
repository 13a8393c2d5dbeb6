"""Checks of a built or read mesh against the scene, before any assembly.

- `check_quads`: every quadrilateral strictly convex with distinct corners (a positive
  cross product of the two edges at each corner), so the Q4 map is invertible. This
  catches repeated nodes, zero-length edges, 180-degree corners, non-convex and
  self-intersecting ("bow-tie") quads that a positive total area lets through.
- `check_interface_bodies`: the slave and master curves of an interface on two bodies.
- `check_overlaps`: bodies that overlap (an element centre of one, or an element corner
  pulled slightly towards its centre, inside an element of the other) must be joined by
  an interface; otherwise they would pass through each other.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from app.errors import InputError
from app.mesh.folds import check_no_folds
from app.mesh.model import Mesh
from app.scene.geometry import MAX_COORDINATE

CORNER_PULL = 1e-3
"""Element corners are tested for overlap moved this fraction of the way to the element
centre: inside their own body, so that bodies that only touch do not overlap."""

CORNER_TOL = 1e-10
"""Smallest accepted corner cross product relative to the product of its edge lengths
(the sine of the corner angle)."""


def corner_sines(points: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Signed sine of each corner angle (ne, 4): cross(next - p, prev - p) / lengths;
    0 for a zero-length edge. Positive at every corner of a convex counter-clockwise quad."""
    p = points[quads]  # (ne, 4, 2)
    a = np.roll(p, -1, axis=1) - p  # edge to the next corner
    b = np.roll(p, 1, axis=1) - p  # edge to the previous corner
    cross = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    norms = np.hypot(a[..., 0], a[..., 1]) * np.hypot(b[..., 0], b[..., 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(norms > 0, cross / np.where(norms > 0, norms, 1.0), 0.0)


def check_quads(mesh: Mesh) -> None:
    """InputError naming the body and place of the first degenerate or non-convex quad."""
    used = np.unique(mesh.quads)
    bad_xy = ~np.all(np.isfinite(mesh.points[used]), axis=1) | np.any(
        np.abs(mesh.points[used]) > MAX_COORDINATE, axis=1)
    if bad_xy.any():
        n = int(used[np.argmax(bad_xy)])
        raise InputError(f"{bad_xy.sum()} mesh node(s) have non-finite or huge coordinates "
                         f"(first: node {n} at {mesh.points[n].tolist()}): fix the mesh")
    s = corner_sines(mesh.points, mesh.quads)
    repeated = np.zeros(len(mesh.quads), dtype=bool)
    q = np.sort(mesh.quads, axis=1)
    repeated |= np.any(q[:, 1:] == q[:, :-1], axis=1)
    bad = np.flatnonzero(repeated | np.any(s <= CORNER_TOL, axis=1))
    if bad.size:
        e = int(bad[0])
        c = mesh.points[mesh.quads[e]].mean(axis=0)
        why = ("repeats a node" if repeated[e] else
               f"has a corner angle of {np.degrees(np.arcsin(np.clip(s[e].min(), -1, 1))):.3g}"
               " degrees (sine <= 0: degenerate, non-convex or self-intersecting)")
        raise InputError(
            f"body '{mesh.body_names[mesh.body[e]]}': {bad.size} degenerate quadrilateral(s); "
            f"the first (element {e}, near x={c[0]:.4g}, y={c[1]:.4g}) {why}: fix the mesh"
        )


def check_interface_bodies(mesh: Mesh, interfaces) -> None:
    """The slave and master curves of each interface must belong to different bodies."""
    nb = mesh.node_body()
    for it in interfaces:
        if it.slave not in mesh.curves or it.master not in mesh.curves:
            continue  # reported by the pair search with the known curve names
        bs = set(nb[mesh.curves[it.slave].ravel()].tolist())
        bm = set(nb[mesh.curves[it.master].ravel()].tolist())
        if bs == bm and len(bs) == 1:
            raise InputError(
                f"interface '{it.name}': slave '{it.slave}' and master '{it.master}' are both "
                f"on body '{mesh.body_names[bs.pop()]}': an interface joins two bodies")


def check_overlaps(mesh: Mesh, interfaces) -> None:
    """Bodies that overlap must be joined by an interface (interference fits are).

    Each body's probe points (element centres, and corners pulled CORNER_PULL towards
    their centre) are tested against each other body whose bounding box overlaps its own
    and that no interface joins to it, every such body at once (one k-d tree per body).
    Before, a Python loop over every ordered pair of bodies built a tree per pair: 22 s of
    the mesh phase at 1000 one-element bodies in a row, 4 times that at 2000."""
    nb = mesh.node_body()
    nbody = len(mesh.body_names)
    joined = np.zeros((nbody, nbody), bool)
    np.fill_diagonal(joined, True)
    for it in interfaces:
        for c1 in (it.slave, it.master):
            for c2 in (it.slave, it.master):
                if c1 in mesh.curves and c2 in mesh.curves:
                    joined[int(nb[mesh.curves[c1][0, 0]]), int(nb[mesh.curves[c2][0, 0]])] = True
    xe = mesh.points[mesh.quads]
    centre = xe.mean(axis=1)
    lo = np.full((nbody, 2), np.inf)
    hi = np.full((nbody, 2), -np.inf)
    np.minimum.at(lo, mesh.body, xe.min(axis=1))
    np.maximum.at(hi, mesh.body, xe.max(axis=1))
    # element centres, and corners pulled CORNER_PULL towards their centre (a thin
    # overlap: before, bodies overlapping by less than half an element passed)
    pulled = (1.0 - CORNER_PULL) * xe + CORNER_PULL * centre[:, None, :]
    probes = np.concatenate([centre, pulled.reshape(-1, 2)])
    owner = np.concatenate([mesh.body, np.repeat(mesh.body, 4)])
    order = np.argsort(owner, kind="stable")  # by body; within one, centres then corners
    probes, owner = probes[order], owner[order]
    for b in range(nbody):
        apart = np.any(lo >= hi[b], axis=1) | np.any(lo[b] >= hi, axis=1)
        others = ~apart & ~joined[:, b] & ~joined[b, :]
        if not others.any():
            continue
        take = others[owner]
        inside = _centres_inside(probes[take], xe[mesh.body == b])
        if inside.any():
            k = int(np.argmax(inside))  # the first point of the first body a that overlaps
            a, c = int(owner[take][k]), probes[take][k]
            raise InputError(
                f"bodies '{mesh.body_names[a]}' and '{mesh.body_names[b]}' overlap (near "
                f"x={c[0]:.4g}, y={c[1]:.4g}) and no [[interface]] joins them: move them "
                "apart or add an interface (interference = true for an intended fit)")


def _centres_inside(pts: np.ndarray, xe: np.ndarray, k: int = 8,
                    chunk: int = 100_000) -> np.ndarray:
    """For each point (n, 2): inside one of the k quads (of xe (m, 4, 2)) nearest to it."""
    centre = xe.mean(axis=1)
    radius = np.max(np.hypot(*(xe - centre[:, None, :]).transpose(2, 0, 1)), axis=1)
    tree = cKDTree(centre)
    return np.concatenate([_inside(pts[s : s + chunk], xe, tree, radius, min(k, len(xe)))
                           for s in range(0, len(pts), chunk)] or [np.zeros(0, bool)])


def _inside(pts: np.ndarray, xe: np.ndarray, tree: cKDTree, radius: np.ndarray,
            k: int) -> np.ndarray:
    dist, idx = tree.query(pts, k=k)
    dist, idx = dist.reshape(len(pts), k), idx.reshape(len(pts), k)
    near = dist <= radius.max()
    q = xe[idx]  # (n, k, 4, 2)
    a = np.roll(q, -1, axis=2) - q
    r = pts[:, None, None, :] - q
    cross = a[..., 0] * r[..., 1] - a[..., 1] * r[..., 0]  # (n, k, 4)
    scale = np.hypot(a[..., 0], a[..., 1]) * radius[idx][..., None]
    return np.any(near & np.all(cross > 1e-9 * scale, axis=2), axis=1)


def check_scene(mesh: Mesh, interfaces) -> None:
    """All checks of this module (quads, folds, interface bodies, overlaps)."""
    check_quads(mesh)
    check_no_folds(mesh)
    check_interface_bodies(mesh, interfaces)
    check_overlaps(mesh, interfaces)
