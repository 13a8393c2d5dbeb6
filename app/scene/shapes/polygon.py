"""A simple polygon: points, counter-clockwise; sides side0, side1, ... one per edge."""

from __future__ import annotations

import numpy as np

from app.errors import InputError
from app.scene.geometry import Piece, polygon_areas, xy_point
from app.scene.shapes.base import Shape
from app.scene.shapes.polygon_simple import crossing_sides

MAX_POINTS = 10_000
"""Corners of one polygon: a polygon is typed, not digitised (a finer outline is a
mesh.file), and the self-intersection test's worst case (a star of thin spikes, whose
sides overlap along both axes) takes 13 s of CPU at 10,000 (a round outline 0.015 s;
scripts/bench_polygon_simple.py)."""


class Polygon(Shape):
    name = "polygon"
    keys = ("points",)

    def sides(self, shape: dict, where: str) -> list[tuple[str, list[Piece]]]:
        pts = shape.get("points")
        if not isinstance(pts, list) or len(pts) < 3:
            raise InputError(f"{where}points must be a list of at least 3 points [x, y]")
        if len(pts) > MAX_POINTS:
            raise InputError(f"{where}points has {len(pts)} points, more than {MAX_POINTS}: "
                             "give the outline fewer corners, or mesh it in gmsh and use "
                             "mesh.file")
        p = np.array([xy_point(q, f"{where}points[{i}]") for i, q in enumerate(pts)])
        q = np.roll(p, -1, axis=0)
        seg = np.hypot(*(q - p).T)
        if np.any(seg <= 1e-12 * max(1.0, float(np.max(seg)))):
            raise InputError(f"{where}points has two equal consecutive points")
        crossing = crossing_sides(p)
        if crossing is not None:
            i, j = crossing
            raise InputError(f"{where}points: side{i} and side{j} cross or overlap: the "
                             "polygon must not intersect itself")
        if polygon_areas(p) <= 0:
            raise InputError(f"{where}points must be counter-clockwise")
        return [(f"side{i}", [Piece.line(p[i], q[i])]) for i in range(len(p))]

    def contains(self, shape: dict, xy: np.ndarray, tol: float) -> bool:
        pts = np.asarray(shape["points"], float)
        q = np.roll(pts, -1, axis=0)
        d = q - pts
        t = np.clip(np.einsum("ij,ij->i", xy - pts, d) / np.einsum("ij,ij->i", d, d), 0, 1)
        if np.min(np.hypot(*(pts + t[:, None] * d - xy).T)) <= tol:
            return False
        x, y = float(xy[0]), float(xy[1])
        crosses = (pts[:, 1] > y) != (q[:, 1] > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = pts[:, 0] + (y - pts[:, 1]) * d[:, 0] / d[:, 1]
        return bool(np.count_nonzero(crosses & (x < xc)) % 2)
