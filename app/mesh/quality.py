"""Element quality at load: corner angles and aspect ratios of the quadrilaterals.

A quad whose corner angle is (numerically) 0 or 180 degrees or more is degenerate (two
nodes on top of each other, three nodes on a line) or not convex: its mapping is not
invertible everywhere and the element stiffness is wrong; that is an InputError naming
the body and the place. Otherwise a one-line summary is returned for the progress output
and summary.json.
"""

from __future__ import annotations

import numpy as np

from app.errors import InputError
from app.mesh.model import Mesh

MIN_ANGLE_DEG = 1e-3
"""Corner angles below this, or above 180 - this, are degenerate (degrees)."""


def corner_angles(xe: np.ndarray) -> np.ndarray:
    """Interior angles (ne, 4) in degrees of counter-clockwise quads xe (ne, 4, 2); a
    reflex (non-convex) corner comes out above 180."""
    prev = np.roll(xe, 1, axis=1) - xe
    nxt = np.roll(xe, -1, axis=1) - xe
    cross = nxt[..., 0] * prev[..., 1] - nxt[..., 1] * prev[..., 0]
    dot = np.sum(nxt * prev, axis=-1)
    ang = np.degrees(np.arctan2(cross, dot))
    return np.where(ang < 0, ang + 360.0, ang)


def aspect_ratios(xe: np.ndarray) -> np.ndarray:
    """Longest over shortest edge (ne,); inf for a zero-length edge."""
    edges = np.linalg.norm(np.roll(xe, -1, axis=1) - xe, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(edges.min(axis=1) > 0, edges.max(axis=1) / edges.min(axis=1), np.inf)


def mesh_quality(mesh: Mesh) -> dict:
    """{"min_corner_angle_deg", "max_corner_angle_deg", "max_aspect_ratio", "where"};
    raises InputError for degenerate or non-convex elements."""
    xe = mesh.points[mesh.quads]
    ang = corner_angles(xe)
    ar = aspect_ratios(xe)
    bad = (ang.min(axis=1) < MIN_ANGLE_DEG) | (ang.max(axis=1) > 180.0 - MIN_ANGLE_DEG) \
        | ~np.isfinite(ar)
    if bad.any():
        e = int(np.flatnonzero(bad)[0])
        c = xe[e].mean(axis=0)
        raise InputError(
            f"body '{mesh.body_names[mesh.body[e]]}': {int(bad.sum())} element(s) are "
            f"degenerate or not convex (first near x={c[0]:.4g}, y={c[1]:.4g}, corner angles "
            f"{', '.join(f'{a:.4g}' for a in ang[e])} deg): fix the mesh")
    worst = int(np.argmin(ang.min(axis=1)))
    c = xe[worst].mean(axis=0)
    out = {"min_corner_angle_deg": float(ang.min()), "max_corner_angle_deg": float(ang.max()),
           "max_aspect_ratio": float(ar.max()), "min_angle_at": [float(c[0]), float(c[1])]}
    if len(mesh.dropped_nodes):
        out["unused_nodes"] = len(mesh.dropped_nodes)
        out["unused_node_at"] = [float(v) for v in mesh.dropped_nodes[0]]
    return out


def quality_line(q: dict) -> str:
    """'mesh quality: corner angles 45-135 deg, aspect ratio <= 2.5'"""
    return (f"mesh quality: corner angles {q['min_corner_angle_deg']:.3g} to "
            f"{q['max_corner_angle_deg']:.4g} deg (smallest near x={q['min_angle_at'][0]:.4g}, "
            f"y={q['min_angle_at'][1]:.4g}), largest aspect ratio "
            f"{q['max_aspect_ratio']:.3g}" + _unused_note(q))


def _unused_note(q: dict) -> str:
    """'; 2 nodes of the file on no quadrilateral dropped (...)' or ''."""
    n = q.get("unused_nodes", 0)
    if not n:
        return ""
    x, y = q["unused_node_at"]
    return (f"; {n} node(s) of the mesh file on no quadrilateral dropped (first at "
            f"x={x:.4g}, y={y:.4g}): they carry no DOF and change nothing")
