"""Geometry primitives of scene shapes: line and arc pieces, and the checked numbers,
points and lengths a shape table is made of (plain numpy, config units)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.errors import InputError

MAX_ARC = 0.5 * math.pi  # longest arc piece (gmsh circle arcs must be < pi)


@dataclass
class Piece:
    """One geometric curve: segment p0 -> p1, or counter-clockwise arc of `center`,
    `radius` from angle a0 to a1 (rad, a0 < a1, a1 - a0 <= pi/2)."""

    kind: str  # "line" | "arc"
    p0: np.ndarray  # (2,) start point
    p1: np.ndarray  # (2,) end point
    center: np.ndarray | None = None
    radius: float = 0.0
    a0: float = 0.0
    a1: float = 0.0

    @staticmethod
    def line(p0: Any, p1: Any) -> Piece:
        """The straight piece from p0 to p1 (points [x, y])."""
        return Piece("line", np.asarray(p0, float), np.asarray(p1, float))

    @staticmethod
    def arc(center: Any, radius: float, a0: float, a1: float) -> Piece:
        """The arc of the circle (center, radius) from angle a0 to a1 (radians)."""
        c = np.asarray(center, float)
        return Piece("arc", _polar(c, radius, a0), _polar(c, radius, a1), c, radius, a0, a1)

    @property
    def length(self) -> float:
        if self.kind == "line":
            return float(np.linalg.norm(self.p1 - self.p0))
        return self.radius * (self.a1 - self.a0)

    def locate(self, xy: np.ndarray, tol: float) -> float | None:
        """Parameter t in (0, 1) of `xy` if it lies on the piece away from its ends, else None."""
        if self.kind == "line":
            d = self.p1 - self.p0
            t = float(np.dot(xy - self.p0, d) / np.dot(d, d))
            dist = float(np.linalg.norm(xy - (self.p0 + t * d)))
        else:
            v = xy - self.center
            dist = abs(float(np.hypot(*v)) - self.radius)
            ang = (math.atan2(v[1], v[0]) - self.a0) % (2.0 * math.pi)
            t = ang / (self.a1 - self.a0)
        length = self.length
        if dist <= tol and tol < t * length < length - tol:
            return t
        return None

    def split(self, t: float) -> list[Piece]:
        """The two pieces on either side of parameter t."""
        if self.kind == "line":
            mid = self.p0 + t * (self.p1 - self.p0)
            return [Piece.line(self.p0, mid), Piece.line(mid, self.p1)]
        am = self.a0 + t * (self.a1 - self.a0)
        return [
            Piece.arc(self.center, self.radius, self.a0, am),
            Piece.arc(self.center, self.radius, am, self.a1),
        ]


def _polar(c: np.ndarray, r: float, a: float) -> np.ndarray:
    return c + r * np.array([math.cos(a), math.sin(a)])


def arc_pieces(center: Any, radius: float, a0: float, a1: float) -> list[Piece]:
    """The arc from angle a0 to a1 (radians) as equal pieces of at most MAX_ARC each."""
    n = max(1, math.ceil((a1 - a0) / MAX_ARC - 1e-9))
    a = np.linspace(a0, a1, n + 1)
    return [Piece.arc(center, radius, a[i], a[i + 1]) for i in range(n)]


def is_number(v: Any) -> bool:
    """True for a finite int or float (not a bool)."""
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def number(d: dict, key: str, where: str, *, minimum: float | None = 0.0,
            strict: bool = True, default: Any = None) -> float:
    """d[key] as a float, checked > minimum (strict) or >= minimum."""
    v = d.get(key, default)
    op = ">" if strict else ">="
    need = "a number" if minimum is None else f"a number {op} {minimum:g}"
    if v is None:
        raise InputError(f"{where}{key} is missing: it must be {need}")
    if not is_number(v) or (
        minimum is not None and (v <= minimum if strict else v < minimum)
    ):
        raise InputError(f"{where}{key} must be {need} (got {v!r})")
    return float(v)


MAX_COORDINATE = 1e30
"""Largest coordinate or length accepted (squares of lengths must stay finite)."""


def xy_point(v: Any, what: str) -> np.ndarray:
    """v as a point (2,) float; InputError naming `what` unless it is two finite
    numbers within +-MAX_COORDINATE."""
    if not (isinstance(v, list | tuple) and len(v) == 2 and all(is_number(c) for c in v)):
        raise InputError(f"{what} must be a point [x, y] (got {v!r})")
    if max(abs(c) for c in v) > MAX_COORDINATE:
        raise InputError(f"{what} = {v!r} is beyond +-{MAX_COORDINATE:g}: check the units")
    return np.array(v, dtype=float)


def length_value(d: dict, key: str, where: str) -> float:
    """A positive length no larger than MAX_COORDINATE."""
    v = number(d, key, where)
    if v > MAX_COORDINATE:
        raise InputError(f"{where}{key} = {v:g} is above {MAX_COORDINATE:g}: check the units")
    return v


def polygon_areas(xy: np.ndarray) -> np.ndarray:
    """Signed (shoelace) areas of polygons xy (..., k, 2); positive when counter-clockwise.

    Formed relative to each polygon's first vertex: with absolute coordinates the products
    carried the round-off of |x|^2, and a scene moved by (1e8, 3e7) read its elements as
    inverted (and its boundary edges flipped, `app.mesh.model.orient_boundary_edges`)."""
    rel = xy - xy[..., :1, :]
    x, y = rel[..., 0], rel[..., 1]
    return 0.5 * np.sum(x * np.roll(y, -1, axis=-1) - np.roll(x, -1, axis=-1) * y, axis=-1)
