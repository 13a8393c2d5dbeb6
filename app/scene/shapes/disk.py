"""A full disk: center, radius; one side, the arc."""

from __future__ import annotations

import math

import numpy as np

from app.errors import InputError
from app.scene.geometry import Piece, arc_pieces, length_value, xy_point
from app.scene.shapes.base import Shape


def center_radius(shape: dict, where: str) -> tuple[np.ndarray, float]:
    """The checked center [x, y] and radius of a round shape."""
    if "center" not in shape:
        raise InputError(f"{where}center is missing: it must be a point [x, y]")
    return xy_point(shape["center"], f"{where}center"), length_value(shape, "radius", where)


def inside_circle(shape: dict, xy: np.ndarray, tol: float) -> bool:
    """True if xy lies inside the shape's circle, further than tol from it."""
    c, r = np.asarray(shape["center"], float), shape["radius"]
    return bool(np.hypot(xy[0] - c[0], xy[1] - c[1]) < r - tol)


class Disk(Shape):
    name = "disk"
    keys = ("center", "radius")
    side_names = ("arc",)

    def sides(self, shape: dict, where: str) -> list[tuple[str, list[Piece]]]:
        center, r = center_radius(shape, where)
        return [("arc", arc_pieces(center, r, 0.0, 2.0 * math.pi))]

    def contains(self, shape: dict, xy: np.ndarray, tol: float) -> bool:
        return inside_circle(shape, xy, tol)
