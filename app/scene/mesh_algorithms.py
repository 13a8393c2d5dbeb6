"""How gmsh meshes an unstructured body: `[mesh] algorithm = NAME` picks one recipe.

A recipe is a set of gmsh `Mesh.*` options (2D algorithm, recombination into quads,
smoothing), applied after the builder's own options; every recipe must leave
quadrilaterals only (both use blossom full-quad recombination: gmsh meshes at twice the
size, recombines and splits every element into quads). A new recipe is one entry in
MESH_ALGORITHMS. Structured (`structured = true`) bodies use a transfinite grid whatever
the recipe. Measured behaviour of each: README "Contact discretisations", Hertz rows.
"""

from __future__ import annotations

from dataclasses import dataclass

from app.config_keys import suggestion
from app.errors import InputError


@dataclass(frozen=True)
class MeshAlgorithm:
    """gmsh options of one recipe (set before `gmsh.model.mesh.generate(2)`)."""

    options: dict[str, float]
    doc: str


MESH_ALGORITHMS: dict[str, MeshAlgorithm] = {
    "delaunay": MeshAlgorithm(
        {"Mesh.Algorithm": 5, "Mesh.RecombinationAlgorithm": 3, "Mesh.Smoothing": 5},
        "Delaunay triangles, full-quad: follows the [[mesh.refine]] size fields at every "
        "size; the quads are irregular (many nodes with 3 or 5 elements)",
    ),
    "frontal-delaunay": MeshAlgorithm(
        {"Mesh.Algorithm": 6, "Mesh.RecombinationAlgorithm": 3, "Mesh.Smoothing": 5},
        "Frontal-Delaunay triangles, full-quad: nearly structured quads under a contact "
        "refined by points (hertz.toml at every size), but on cattaneo.toml it left half "
        "the elements and angles of 11-173 deg (the size field not followed inside)",
    ),
    "frontal-quad": MeshAlgorithm(
        {"Mesh.Algorithm": 8, "Mesh.RecombinationAlgorithm": 3, "Mesh.Smoothing": 5},
        "Frontal-Delaunay for quads, full-quad: nearly structured quads where the size is "
        "constant; at hertz.toml's a/10 and a/20 it followed the size field only in a "
        "layer along the boundary (coarse quads behind it, angles up to 175 deg)",
    ),
}
DEFAULT_MESH_ALGORITHM = "delaunay"
BASE_OPTIONS = {"Mesh.Algorithm": 6, "Mesh.RecombinationAlgorithm": 1, "Mesh.Smoothing": 1}
"""gmsh's defaults of the options a recipe may set, so no recipe leaks into the next."""


def gmsh_options(name: str) -> dict[str, float]:
    """All gmsh options of recipe `name`: BASE_OPTIONS overridden by the recipe's own."""
    return BASE_OPTIONS | MESH_ALGORITHMS[name].options


def mesh_algorithm(name: object, where: str = "mesh.algorithm") -> str:
    """The validated recipe name (InputError naming the choices otherwise)."""
    if not isinstance(name, str) or name not in MESH_ALGORITHMS:
        hint = suggestion(name, list(MESH_ALGORITHMS)) if isinstance(name, str) else ""
        raise InputError(f"{where} must be one of {', '.join(MESH_ALGORITHMS)} "
                         f"(got {name!r}){hint}")
    return name
