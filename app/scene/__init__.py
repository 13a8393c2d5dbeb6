"""The scene's geometry as typed data (see parse.py); shapes in app/scene/shapes/."""

from app.scene.parse import BodySpec, Patch, Refine, Scene, Side, parse_scene

__all__ = ["BodySpec", "Patch", "Refine", "Scene", "Side", "parse_scene"]
