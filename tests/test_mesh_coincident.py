"""Nodes of one body at one place in a read .msh (a cut body) are an error."""

from pathlib import Path

import numpy as np
import pytest
from test_mesh import write_msh

from app.errors import InputError
from app.mesh.coincident import check_coincident_nodes
from app.mesh.read import read_mesh

# two unit squares side by side; the right one has its own nodes on x = 1
POINTS = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [1, 0], [2, 0], [2, 1], [1, 1]], float)
QUADS = np.array([[0, 1, 2, 3], [4, 5, 6, 7]])


def test_coincident_nodes_of_one_body_are_an_error() -> None:
    with pytest.raises(InputError, match=r"body 'block' has 2 pair\(s\) of nodes at the same "
                                         r"place \(first near x=1, y=0\)"):
        check_coincident_nodes(POINTS, QUADS, np.array([0, 0]), ["block"], "m.msh")


def test_coincident_nodes_of_two_bodies_are_fine() -> None:
    check_coincident_nodes(POINTS, QUADS, np.array([0, 1]), ["left", "right"], "m.msh")
    joined = np.array([[0, 1, 2, 3], [1, 5, 6, 2]])  # the same squares sharing x = 1
    check_coincident_nodes(POINTS, joined, np.array([0, 0]), ["block"], "m.msh")


def _one_body(path: Path, shared: bool) -> Path:
    """write_msh's two squares, then both surfaces put into one physical surface."""
    import gmsh

    write_msh(path, shared=shared)
    gmsh.initialize([], readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        surfaces = [t for _, t in gmsh.model.getEntities(2)]
        gmsh.model.removePhysicalGroups(gmsh.model.getPhysicalGroups(2))
        gmsh.model.addPhysicalGroup(2, surfaces, name="block")
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def test_a_msh_body_meshed_in_unjoined_pieces_is_refused(tmp_path: Path) -> None:
    """Before, the cut body ran without a word."""
    with pytest.raises(InputError, match="body 'block' has 3 pair"):
        read_mesh(_one_body(tmp_path / "cut.msh", shared=False), ["block"])
    m = read_mesh(_one_body(tmp_path / "joined.msh", shared=True), ["block"])
    assert m.n_elements == 8 and m.n_nodes == 15
