"""gmsh's 2D meshing with a retry for curves shorter than the element size.

The full-quad recipes (app/scene/mesh_algorithms.py) mesh at twice the element size and
split every element; a curve shorter than about the element size gets one segment at
the doubled size, and gmsh stops with "1D mesh cannot be divided by 2". That made a layer
thinner than the element size unmeshable (a 2 x 0.15 polygon at size 0.2; hertz.toml at
--mesh-size 10). The retry gives those curves two segments and meshes again.
"""

from __future__ import annotations

from typing import Any

SHORT_CURVE_ERROR = "cannot be divided by 2"


def generate_quads(gmsh: Any) -> None:
    """gmsh.model.mesh.generate(2), once more with 2 segments on every curve that got
    at most 1 when gmsh stopped on a too short curve. Raises gmsh's exception otherwise."""
    try:
        gmsh.model.mesh.generate(2)
        return
    except Exception as exc:  # gmsh raises a bare Exception with its last error
        if SHORT_CURVE_ERROR not in str(exc):
            raise
        short = [tag for _, tag in gmsh.model.getEntities(1)
                 if sum(len(n) for n in gmsh.model.mesh.getElements(1, tag)[2]) <= 2]
        if not short:
            raise
    gmsh.model.mesh.clear()
    for tag in short:
        gmsh.model.mesh.setTransfiniteCurve(tag, 3)
    gmsh.model.mesh.generate(2)
