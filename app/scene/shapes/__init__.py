"""The registry of body shapes: a new shape is one file with a `Shape` subclass and one
entry in SHAPES (see rectangle.py)."""

from __future__ import annotations

from app.scene.shapes.base import Shape
from app.scene.shapes.disk import Disk
from app.scene.shapes.half_disk import HalfDisk
from app.scene.shapes.polygon import Polygon
from app.scene.shapes.rectangle import Rectangle

SHAPES: dict[str, Shape] = {s.name: s for s in (Rectangle(), HalfDisk(), Disk(), Polygon())}

__all__ = ["SHAPES", "Shape"]
