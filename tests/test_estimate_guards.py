"""The size estimate before meshing: huge refinement lengths (no traceback) and
structured patches (counted), so a config cannot slip a huge mesh past the check."""

from __future__ import annotations

import copy
import math
import tomllib

from support import CONFIGS

from app.mesh.estimate import estimate
from app.scene import parse_scene

HERTZ = tomllib.loads((CONFIGS / "hertz.toml").read_text())


def test_huge_refinement_lengths_give_an_estimate_not_an_overflow():
    """Before: `flat = 1e300` raised OverflowError in the estimate (a traceback, exit 1)."""
    raw = copy.deepcopy(HERTZ)
    raw["mesh"]["refine"][0].update(flat=1e300, distance=1e300)
    est = estimate(parse_scene(raw), 1.0)
    area = 8.0 * 4.0 + 0.5 * math.pi  # the whole of both bodies at the refined size
    assert math.isfinite(est.elements)
    assert est.elements <= 1.01 * (area / 0.01**2 + 2 * area / 0.5**2)
