"""On-disk cache of built meshes: one compressed .npz per hash of the geometry input."""

from __future__ import annotations

import hashlib
import json
import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from app.mesh.model import Mesh

# Bump when the meshing code changes in a way that changes the meshes it builds.
CACHE_FORMAT = 1


def cache_key(payload: dict[str, Any]) -> str:
    """Hex SHA-256 (first 20 chars) of a JSON-serialisable description of the mesh input."""
    text = json.dumps({"format": CACHE_FORMAT, **payload}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def cache_path(cache_dir: str | Path, key: str) -> Path:
    """Path of the cache file for `key` inside `cache_dir`."""
    return Path(cache_dir) / f"mesh-{key}.npz"


def save_mesh(path: str | Path, mesh: Mesh) -> None:
    """Write `mesh` to a compressed .npz at `path` (atomically: write then rename)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, np.ndarray] = {
        "points": mesh.points,
        "quads": mesh.quads,
        "body": mesh.body,
        "body_names": np.array(mesh.body_names, dtype=str),
        "curve_names": np.array(list(mesh.curves), dtype=str),
        "point_names": np.array(list(mesh.point_groups), dtype=str),
    }
    for i, edges in enumerate(mesh.curves.values()):
        arrays[f"curve_{i}"] = edges
    for i, nodes in enumerate(mesh.point_groups.values()):
        arrays[f"point_{i}"] = nodes
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    with open(tmp, "wb") as f:
        np.savez_compressed(f, **arrays)
    os.replace(tmp, path)


def load_mesh(path: str | Path) -> Mesh | None:
    """Read a mesh written by `save_mesh`; None if the file is missing or unreadable."""
    try:
        with np.load(Path(path), allow_pickle=False) as data:
            curve_names = [str(s) for s in data["curve_names"]]
            point_names = [str(s) for s in data["point_names"]]
            return Mesh(
                points=data["points"],
                quads=data["quads"],
                body=data["body"],
                body_names=[str(s) for s in data["body_names"]],
                curves={n: data[f"curve_{i}"] for i, n in enumerate(curve_names)},
                point_groups={n: data[f"point_{i}"] for i, n in enumerate(point_names)},
            )
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        return None
