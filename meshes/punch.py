"""Writes meshes/punch.msh: a flat punch pressed on a block, two bodies, linear quads.

    .venv/bin/python meshes/punch.py

Physical surfaces (bodies): "block" [-1, 1] x [-1, 0] and "punch" [-0.25, 0.25] x [0, 0.5].
Physical curves: "block_base" (y = -1), "block_top" (y = 0), "punch_bottom" (y = 0),
"punch_top" (y = 0.5). The two bodies touch along y = 0 and share no node.
"""

from pathlib import Path

import gmsh


def rectangle(geo, x0, y0, x1, y1, sizes):
    """Four corner points (sizes per corner), four lines bottom, right, top, left."""
    p = [geo.addPoint(x, y, 0, h) for (x, y), h in
         zip([(x0, y0), (x1, y0), (x1, y1), (x0, y1)], sizes, strict=True)]
    lines = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
    return geo.addPlaneSurface([geo.addCurveLoop(lines)]), lines


def main(path: Path) -> None:
    gmsh.initialize([], readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("punch")
        geo = gmsh.model.geo
        block, bl = rectangle(geo, -1.0, -1.0, 1.0, 0.0, [0.2, 0.2, 0.05, 0.05])
        punch, pl = rectangle(geo, -0.25, 0.0, 0.25, 0.5, [0.04, 0.04, 0.08, 0.08])
        geo.synchronize()
        for name, tag in (("block", block), ("punch", punch)):
            gmsh.model.addPhysicalGroup(2, [tag], name=name)
        for name, line in (("block_base", bl[0]), ("block_top", bl[2]),
                           ("punch_bottom", pl[0]), ("punch_top", pl[2])):
            gmsh.model.addPhysicalGroup(1, [line], name=name)
        gmsh.option.setNumber("Mesh.Algorithm", 8)  # frontal-Delaunay for quads
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1)  # all quadrilaterals
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main(Path(__file__).with_name("punch.msh"))
