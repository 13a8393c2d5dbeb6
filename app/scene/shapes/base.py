"""What a body shape provides to the mesh builder."""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from app.scene.geometry import Piece


class Shape(ABC):
    """A body shape of `[body.shape]`.

    name: the `type` value; keys: its geometry keys (besides type, structured, divisions);
    side_names: the names of its sides counter-clockwise ((): numbered side0, side1, ...);
    structured: True when `structured = true` (a transfinite grid) is supported.
    """

    name: str = ""
    keys: tuple[str, ...] = ()
    side_names: tuple[str, ...] = ()
    structured: bool = False

    @abstractmethod
    def sides(self, shape: dict, where: str) -> list[tuple[str, list[Piece]]]:
        """The checked sides (name, pieces), counter-clockwise; InputError naming the key."""

    @abstractmethod
    def contains(self, shape: dict, xy: np.ndarray, tol: float) -> bool:
        """True if xy lies strictly inside (further than tol from the boundary)."""
