"""Structured contact patches (`[[mesh.patch]]`): a body surface cut by a box, the piece
inside the box meshed as a transfinite grid of square-ish quads.

A body that a patch box meets is built with gmsh's OpenCASCADE kernel: its surface is
fragmented by the boxes (`occ.fragment`), the parts of the boxes outside the body are
removed, and every piece of the body inside a box becomes a transfinite, recombined
surface with `size` quads. The piece needs exactly 4 corners (boundary vertices where the
boundary turns by more than CORNER_ANGLE): a box under a rectangle's side gives a
rectangle, a box across the bottom of a disk a region of an arc, two vertical lines and
a line. Every other vertex (an arc split, a named point) lies inside a side. The rest of
the body is meshed as without patches (the recipe and the [[mesh.refine]] size fields),
conforming along the cut lines. The named sides are found again after the cut by where
each boundary curve lies, so every named curve keeps all its pieces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from app.errors import InputError
from app.scene import BodySpec, Patch

CORNER_ANGLE = math.radians(30.0)
"""A boundary vertex of a patch piece is a corner when the boundary turns by more."""


@dataclass
class PatchPlan:
    """The transfinite settings of one patch piece, applied after the last synchronize."""

    surface: int
    corners: list[int]  # 4 vertex tags, in boundary order
    counts: list[tuple[int, int]]  # (curve tag, number of nodes)


def patches_meeting(spec: BodySpec, patches: list[Patch]) -> list[tuple[int, Patch]]:
    """(index, patch) of the patches whose box overlaps the body's bounding box."""
    pts = np.array([q for s in spec.sides for p in s.pieces for q in _piece_extent(p)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    return [(i, p) for i, p in enumerate(patches)
            if p.box[0] < hi[0] and p.box[2] > lo[0] and p.box[1] < hi[1] and p.box[3] > lo[1]]


def _piece_extent(p: Any) -> list[np.ndarray]:
    """Points whose bounding box holds the piece (arc: ends and its axis extremes)."""
    if p.kind == "line":
        return [p.p0, p.p1]
    out = [p.p0, p.p1]
    for k in range(-4, 9):
        a = 0.5 * math.pi * k
        if p.a0 <= a <= p.a1:
            out.append(p.center + p.radius * np.array([math.cos(a), math.sin(a)]))
    return out


def cut(gmsh: Any, spec: BodySpec, surf: int, meeting: list[tuple[int, Patch]],
        scale: float) -> tuple[list[int], list[list[int]], list[PatchPlan]]:
    """Fragment OCC surface `surf` by the patch boxes and synchronize.

    Returns the body's surfaces, the curve tags of each side of `spec.sides` after the cut
    and the transfinite plan of every piece inside a box. InputError (one line, naming
    the body and the patch) when a piece has not 4 corners or two patches overlap.
    """
    occ = gmsh.model.occ
    span = max(float(np.ptp([p.p0 for s in spec.sides for p in s.pieces], axis=0).max()),
               1e-300)
    boxes = [occ.addRectangle(p.box[0], p.box[1], 0.0, p.box[2] - p.box[0],
                              p.box[3] - p.box[1]) for _, p in meeting]
    _, maps = occ.fragment([(2, surf)], [(2, b) for b in boxes])
    body = {t for d, t in maps[0] if d == 2}
    inside: dict[int, int] = {}  # body surface -> index into meeting
    outside = set()
    for k, m in enumerate(maps[1:]):
        for d, t in m:
            if d != 2:
                continue
            if t not in body:
                outside.add(t)
            elif t in inside:
                raise InputError(f"body '{spec.name}': mesh.patch[{meeting[inside[t]][0]}] "
                                 f"and mesh.patch[{meeting[k][0]}] overlap")
            else:
                inside[t] = k
    if outside:
        occ.remove([(2, t) for t in sorted(outside)], recursive=True)
    occ.synchronize()
    side_tags = _side_curves(gmsh, spec, sorted(body), 1e-7 * span)
    plans = [_plan(gmsh, spec, s, meeting[k], scale) for s, k in sorted(inside.items())]
    return sorted(body), side_tags, plans


def _side_curves(gmsh: Any, spec: BodySpec, surfaces: list[int], tol: float) -> list[list[int]]:
    """Curve tags of each side: the body's boundary curves whose midpoint lies on it."""
    bnd = gmsh.model.getBoundary([(2, s) for s in surfaces], combined=True, oriented=False)
    out: list[list[int]] = [[] for _ in spec.sides]
    for _, c in bnd:
        c = abs(c)
        lo, hi = gmsh.model.getParametrizationBounds(1, c)
        xy = np.asarray(gmsh.model.getValue(1, c, [0.5 * (lo[0] + hi[0])]))[:2]
        for k, s in enumerate(spec.sides):
            if any(p.locate(xy, tol) is not None for p in s.pieces):
                out[k].append(c)
                break
    return out


def _plan(gmsh: Any, spec: BodySpec, surface: int, patch: tuple[int, Patch],
          scale: float) -> PatchPlan:
    """Corners and node counts of one piece (InputError unless it has 4 corners)."""
    index, p = patch
    loop = _boundary_loop(gmsh, surface)
    turns = [_turn(gmsh, loop[k - 1], loop[k]) for k in range(len(loop))]
    first = [k for k, t in enumerate(turns) if t > CORNER_ANGLE]
    if len(first) != 4:
        raise InputError(
            f"body '{spec.name}': the part of mesh.patch[{index}] inside it has "
            f"{len(first)} corners, not 4: move the box so that it cuts the body into a "
            "four-sided region")
    sides = [loop[first[k]:first[k + 1]] if k < 3 else loop[first[3]:] + loop[:first[0]]
             for k in range(4)]
    lengths = [[gmsh.model.occ.getMass(1, abs(c)) for c, _, _ in s] for s in sides]
    h = p.size * scale
    counts = []
    for pair in ((0, 2), (1, 3)):
        # even intervals on every curve: the full-quad recipes mesh curves at half the
        # count and split every element in four
        n = max(1, round(0.25 * sum(sum(lengths[k]) for k in pair) / h),
                *(len(sides[k]) for k in pair))
        for k in pair:
            for (c, _, _), m in zip(sides[k], _split(lengths[k], n), strict=True):
                counts.append((abs(c), 2 * int(m) + 1))
    return PatchPlan(surface, [loop[k][1] for k in first], counts)


def _boundary_loop(gmsh: Any, surface: int) -> list[tuple[int, int, int]]:
    """The surface's outer boundary as (curve, start vertex, end vertex) in order."""
    curves = [abs(c) for _, c in gmsh.model.getBoundary([(2, surface)], oriented=False)]
    ends = {c: [v for _, v in gmsh.model.getBoundary([(1, c)], oriented=False)]
            for c in curves}
    c0 = curves[0]
    loop = [(c0, ends[c0][0], ends[c0][-1])]
    left = set(curves[1:])
    while left:
        v = loop[-1][2]
        nxt = next((c for c in left if v in ends[c]), None)
        if nxt is None:
            raise InputError(f"surface {surface}: its boundary is not one closed loop "
                             "(a patch box with a hole in it?)")
        a, b = ends[nxt][0], ends[nxt][-1]
        loop.append((nxt, a, b) if a == v else (nxt, b, a))
        left.discard(nxt)
    return loop


def _turn(gmsh: Any, prev: tuple[int, int, int], cur: tuple[int, int, int]) -> float:
    """Angle (rad) the boundary turns by at the vertex where `prev` ends and `cur` starts."""
    return float(math.acos(np.clip(np.dot(_tangent(gmsh, prev, end=True),
                                          _tangent(gmsh, cur, end=False)), -1.0, 1.0)))


def _tangent(gmsh: Any, item: tuple[int, int, int], end: bool) -> np.ndarray:
    """Unit tangent along the loop direction at the start (end=False) or end of a curve."""
    c, a, _ = item
    lo, hi = gmsh.model.getParametrizationBounds(1, c)
    start = np.asarray(gmsh.model.getValue(1, c, [lo[0]]))[:2]
    va = np.asarray(gmsh.model.getValue(0, a, []))[:2]
    end_ = np.asarray(gmsh.model.getValue(1, c, [hi[0]]))[:2]
    forward = np.linalg.norm(start - va) <= np.linalg.norm(end_ - va)  # along the param.
    t = (hi[0] if forward else lo[0]) if end else (lo[0] if forward else hi[0])
    d = np.asarray(gmsh.model.getDerivative(1, c, [t]))[:2] * (1.0 if forward else -1.0)
    return d / np.linalg.norm(d)


def _split(lengths: list[float], n: int) -> list[int]:
    """n >= len(lengths) intervals over consecutive curves in proportion to their lengths
    (each >= 1; rounded cumulative shares, as app.mesh.build's structured sides)."""
    cum = np.cumsum(lengths) / np.sum(lengths)
    b = [int(math.floor(c * n + 0.5)) for c in cum]  # a few curves: plain loops
    b[-1] = n
    for k in range(len(b)):
        b[k] = max(b[k], (b[k - 1] if k else 0) + 1)
    for k in range(len(b) - 2, -1, -1):
        b[k] = min(b[k], b[k + 1] - 1)
    return [int(d) for d in np.diff([0, *b])]


def apply(gmsh: Any, plans: list[PatchPlan]) -> None:
    """Set the transfinite curves and surfaces of the pieces (after the last synchronize)."""
    for plan in plans:
        for c, m in plan.counts:
            gmsh.model.mesh.setTransfiniteCurve(c, m)
        gmsh.model.mesh.setTransfiniteSurface(plan.surface, "Left", plan.corners)
        gmsh.model.mesh.setRecombine(2, plan.surface)
