"""Half a disk: center, radius and the kept side (upper, left, lower, right); sides arc
and flat."""

from __future__ import annotations

import math

import numpy as np

from app.errors import InputError
from app.scene.geometry import Piece, arc_pieces
from app.scene.shapes.base import Shape
from app.scene.shapes.disk import center_radius, inside_circle

HALF_DISK_START = {"upper": 0.0, "left": 0.5 * math.pi, "lower": math.pi, "right": 1.5 * math.pi}
"""Angle (rad) where the arc of each kept half starts, counter-clockwise."""


class HalfDisk(Shape):
    name = "half_disk"
    keys = ("center", "radius", "side")
    side_names = ("arc", "flat")

    def sides(self, shape: dict, where: str) -> list[tuple[str, list[Piece]]]:
        center, r = center_radius(shape, where)
        side = shape.get("side")
        if not isinstance(side, str) or side not in HALF_DISK_START:
            raise InputError(
                f"{where}side must be one of {', '.join(HALF_DISK_START)} (got {side!r})"
            )
        a0 = HALF_DISK_START[side]
        arc = arc_pieces(center, r, a0, a0 + math.pi)
        return [("arc", arc), ("flat", [Piece.line(arc[-1].p1, arc[0].p0)])]

    def contains(self, shape: dict, xy: np.ndarray, tol: float) -> bool:
        if not inside_circle(shape, xy, tol):
            return False
        c = np.asarray(shape["center"], float)
        mid = HALF_DISK_START[shape["side"]] + 0.5 * math.pi  # direction into the kept half
        return (xy[0] - c[0]) * math.cos(mid) + (xy[1] - c[1]) * math.sin(mid) > tol
