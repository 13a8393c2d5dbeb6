"""Writes the Hertz scene of configs/hertz.toml with a structured (transfinite) patch of
square quads under the contact in both bodies, as a .msh for `mesh.file`.

    .venv/bin/python meshes/hertz_patch.py --scale 0.25 --out /tmp/hertz_patch.msh
    .venv/bin/python -m app run configs/hertz.toml --set mesh.file='"/tmp/hertz_patch.msh"' \\
        --out /tmp/hp

Scale 1 is hertz.toml's mesh (contact element 0.01 = a/10), 0.5 a/20, 0.25 a/40. Patches:
the block's [-0.12, 0.12] x [-0.08, 0] and the cylinder's annular sector of the same width
and depth at its bottom, both with the contact element size; the rest is Delaunay with
blossom recombination under hertz.toml's size field, and every element is split once
(`Mesh.SubdivisionAlgorithm = 1`: all quads), so everything is meshed at twice the size
first. Physical groups carry the config's body and curve names. A demonstration of what
a structured contact zone does to p (README "Hertz and the mesh"), not a general tool:
the mesh builder does this with `[[mesh.patch]]` (configs/hertz_patch.toml).
"""

from __future__ import annotations

import argparse
import math

import gmsh

W, D = 0.12, 0.08  # patch half-width and depth: inside the refinement's flat zone (0.15)
R, CY = 1.0, 1.0  # cylinder radius and centre height


def block(geo, h: float) -> tuple[list[int], dict[str, list[int]]]:
    """The 8 x 4 block with its top patch; surfaces and named curves."""
    a, b, c, d = (geo.addPoint(x, y, 0) for x, y in [(-4, -4), (4, -4), (4, 0), (-4, 0)])
    p1, p2, p3, p4 = (geo.addPoint(x, y, 0) for x, y in [(-W, 0), (W, 0), (W, -D), (-W, -D)])
    base, right, top_r, top_p, top_l, left = (geo.addLine(*e) for e in
                                              [(a, b), (b, c), (c, p2), (p2, p1), (p1, d),
                                               (d, a)])
    s1, s2, s3 = geo.addLine(p1, p4), geo.addLine(p4, p3), geo.addLine(p3, p2)
    rest = geo.addPlaneSurface([geo.addCurveLoop([base, right, top_r, -s3, -s2, -s1, top_l,
                                                  left])])
    patch = geo.addPlaneSurface([geo.addCurveLoop([top_p, s1, s2, s3])])
    for curve, length in ((top_p, 2 * W), (s2, 2 * W), (s1, D), (s3, D)):
        geo.mesh.setTransfiniteCurve(curve, _count(length, h) + 1)
    geo.mesh.setTransfiniteSurface(patch, "Left", [p2, p1, p4, p3])
    return [rest, patch], {"base": [base], "block_top": [top_r, top_p, top_l],
                           "block_sides": [right, left]}


def cylinder(geo, h: float) -> tuple[list[int], dict[str, list[int]]]:
    """The lower half-disk with its bottom sector patch; surfaces and named curves."""
    o = geo.addPoint(0, CY, 0)
    phi = math.asin(W / R)

    def polar(r: float, t: float) -> int:
        return geo.addPoint(r * math.cos(t), CY + r * math.sin(t), 0)

    left, right = geo.addPoint(-R, CY, 0), geo.addPoint(R, CY, 0)
    q1, q2 = polar(R, 1.5 * math.pi - phi), polar(R, 1.5 * math.pi + phi)
    q4, q3 = polar(R - D, 1.5 * math.pi - phi), polar(R - D, 1.5 * math.pi + phi)
    arc_l, arc_p, arc_r = (geo.addCircleArc(u, o, v) for u, v in
                           [(left, q1), (q1, q2), (q2, right)])
    inner = geo.addCircleArc(q4, o, q3)
    r1, r2, flat = geo.addLine(q1, q4), geo.addLine(q2, q3), geo.addLine(right, left)
    rest = geo.addPlaneSurface([geo.addCurveLoop([arc_l, r1, inner, -r2, arc_r, flat])])
    patch = geo.addPlaneSurface([geo.addCurveLoop([arc_p, r2, -inner, -r1])])
    for curve, length in ((arc_p, 2 * phi * R), (inner, 2 * phi * R), (r1, D), (r2, D)):
        geo.mesh.setTransfiniteCurve(curve, _count(length, h) + 1)
    geo.mesh.setTransfiniteSurface(patch, "Left", [q1, q2, q3, q4])
    return [rest, patch], {"cyl_arc": [arc_l, arc_p, arc_r], "cyl_top": [flat]}


def _count(length: float, h: float) -> int:
    """Intervals before the final split into four (so 2 x this many after it)."""
    return max(1, round(length / (2 * h)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=float, default=1.0)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    h, big = 0.01 * args.scale, 0.5 * args.scale  # hertz.toml: refine size, mesh.size
    gmsh.initialize([], readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        geo = gmsh.model.geo
        bodies = {"cylinder": cylinder(geo, h), "block": block(geo, h)}
        centre = geo.addPoint(0, 0, 0)
        geo.synchronize()
        fm = gmsh.model.mesh.field
        dist = fm.add("Distance")
        fm.setNumbers(dist, "PointsList", [centre])
        thr = fm.add("Threshold")  # hertz.toml's [[mesh.refine]], at twice the size
        for key, value in (("InField", dist), ("SizeMin", 2 * h), ("SizeMax", 2 * big),
                           ("DistMin", 0.15), ("DistMax", 0.75)):
            fm.setNumber(thr, key, value)
        fm.setAsBackgroundMesh(thr)
        for key, value in (("Mesh.Algorithm", 5), ("Mesh.RecombineAll", 1),
                           ("Mesh.RecombinationAlgorithm", 1), ("Mesh.SubdivisionAlgorithm", 1),
                           ("Mesh.Smoothing", 5), ("Mesh.MeshSizeFromPoints", 0),
                           ("Mesh.MeshSizeFromCurvature", 0),
                           ("Mesh.MeshSizeExtendFromBoundary", 0),
                           ("Mesh.MeshSizeMax", 2 * big), ("Mesh.MshFileVersion", 4.1)):
            gmsh.option.setNumber(key, value)
        model = gmsh.model
        for name, (surfaces, curves) in bodies.items():
            model.setPhysicalName(2, model.addPhysicalGroup(2, surfaces), name)
            for cname, tags in curves.items():
                model.setPhysicalName(1, model.addPhysicalGroup(1, tags), cname)
        model.mesh.generate(2)
        gmsh.write(args.out)
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main()
