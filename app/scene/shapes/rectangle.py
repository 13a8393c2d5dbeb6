"""An axis-aligned rectangle: origin (lower left corner), width, height."""

from __future__ import annotations

import numpy as np

from app.errors import InputError
from app.scene.geometry import Piece, length_value, xy_point
from app.scene.shapes.base import Shape


class Rectangle(Shape):
    name = "rectangle"
    keys = ("origin", "width", "height")
    side_names = ("bottom", "right", "top", "left")
    structured = True

    def sides(self, shape: dict, where: str) -> list[tuple[str, list[Piece]]]:
        if "origin" not in shape:
            raise InputError(f"{where}origin is missing: it must be a point [x, y]")
        x0, y0 = xy_point(shape["origin"], f"{where}origin")
        wd = length_value(shape, "width", where)
        ht = length_value(shape, "height", where)
        c = [(x0, y0), (x0 + wd, y0), (x0 + wd, y0 + ht), (x0, y0 + ht)]
        return [(self.side_names[i], [Piece.line(c[i], c[(i + 1) % 4])]) for i in range(4)]

    def contains(self, shape: dict, xy: np.ndarray, tol: float) -> bool:
        (x0, y0), w, h = shape["origin"], shape["width"], shape["height"]
        x, y = float(xy[0]), float(xy[1])
        return x0 + tol < x < x0 + w - tol and y0 + tol < y < y0 + h - tol
