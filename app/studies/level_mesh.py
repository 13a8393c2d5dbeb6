"""The gmsh mesh of a study level, built once before the level's runs.

Every run reads its gmsh mesh from the study's mesh cache (app/mesh/cache.py) when it is
there, and builds and stores it otherwise. Without this step the first method of each
level (level 0 when levels are split, every level with --remesh) paid the gmsh time in
its `t_mesh` and `t_total` and the others did not, so the error-against-time front ranked
methods by their place in --methods. Building the mesh here first gives every run of a
level the same cached mesh: each run's time is then reading it and splitting it
(`refine`), the same for every method, and the gmsh seconds are the level's own column
`t_level_gmsh`.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from petsc4py import PETSc

from app.config import Config
from app.parallel import collective


def build_level_mesh(cfg: Config, scale: float, cache_dir: Path,
                     progress: str | None = None) -> float:
    """Seconds (rank 0, broadcast) to build the gmsh mesh of cfg's scene at element-size
    scale `scale` into cache_dir, or to read it from there if an earlier study built it;
    0 for a scene read from mesh.file (no gmsh, no cache). NaN if the mesh cannot be
    built: the runs then report the error themselves, as without this step (no line
    then). progress: the prefix of a line printed on rank 0 when the mesh is ready (None:
    no line)."""
    if cfg.scene.file is not None:
        return 0.0

    def build() -> float:
        from app.mesh.build import build_mesh

        started = time.perf_counter()
        try:
            build_mesh(cfg.scene, scale=scale, cache_dir=cache_dir, base_dir=cfg.path.parent)
        except Exception:  # the runs raise it again, each in its own guard
            return math.nan
        return time.perf_counter() - started

    seconds = float(collective(build))
    shown = progress is not None and math.isfinite(seconds)  # (NaN: no mesh is ready)
    if shown and PETSc.COMM_WORLD.getRank() == 0:
        print(f"{progress}: gmsh mesh ready in {seconds:.2f} s (every method reads it from "
              f"{cache_dir.name})", flush=True)
    return seconds
