"""The registry of body shapes: a new shape is one file with a `Shape` subclass and one
entry in SHAPES (see rectangle.py)."""

from __future__ import annotations

from app.mesh.shapes.base import Shape
from app.mesh.shapes.disk import Disk
from app.mesh.shapes.half_disk import HalfDisk
from app.mesh.shapes.polygon import Polygon
from app.mesh.shapes.rectangle import Rectangle

SHAPES: dict[str, Shape] = {s.name: s for s in (Rectangle(), HalfDisk(), Disk(), Polygon())}

__all__ = ["SHAPES", "Shape"]
