"""The mesh data model shared by every later stage.

A `Mesh` holds one quadrilateral mesh of all bodies of a scene. Bodies never share
nodes. Element connectivity is counter-clockwise (positive area). Named curves are
lists of boundary edges (node pairs); named points are node indices.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Mesh:
    """All-quadrilateral multi-body mesh.

    points: (n_nodes, 2) float coordinates, in the config's length unit.
    quads: (n_elements, 4) int node indices, counter-clockwise.
    body: (n_elements,) int body index into `body_names`.
    body_names: names of the bodies (physical surfaces), in body-index order.
    curves: physical curve name -> (n_edges, 2) int node pairs (boundary edges).
    point_groups: physical point name -> (k,) int node indices.
    """

    points: np.ndarray
    quads: np.ndarray
    body: np.ndarray
    body_names: list[str]
    curves: dict[str, np.ndarray] = field(default_factory=dict)
    point_groups: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def n_nodes(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_elements(self) -> int:
        return int(self.quads.shape[0])

    def node_body(self) -> np.ndarray:
        """(n_nodes,) body index of every node (-1 for a node used by no element)."""
        nb = np.full(self.n_nodes, -1, dtype=np.int64)
        nb[self.quads.ravel()] = np.repeat(self.body, 4)
        return nb

    def curve_nodes(self, name: str) -> np.ndarray:
        """Sorted unique node indices of a named curve."""
        return np.unique(self.curves[name])

    def group_nodes(self, name: str) -> np.ndarray:
        """Nodes of a named curve or a named point group."""
        if name in self.curves:
            return self.curve_nodes(name)
        return np.unique(self.point_groups[name])
