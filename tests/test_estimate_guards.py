"""The size estimate before meshing: huge refinement lengths (no traceback) and
structured patches (counted), so a config cannot slip a huge mesh past the check."""

from __future__ import annotations

import copy
import math
import tomllib

import pytest
from support import CONFIGS

from app.errors import InputError
from app.mesh.estimate import check_size, estimate
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


PATCHED = tomllib.loads((CONFIGS / "hertz_patch.toml").read_text())


def test_a_tiny_patch_size_is_refused_before_meshing():
    """Before: `[[mesh.patch]] size = 1e-5` (3.8e8 quads in the box) passed the check,
    and gmsh meshed until the memory ran out."""
    raw = copy.deepcopy(PATCHED)
    raw["mesh"]["patch"][0]["size"] = 1e-5
    with pytest.raises(InputError, match="more than this machine"):
        check_size(parse_scene(raw), 1.0)
    raw["mesh"]["patch"][0]["size"] = 0.0025  # 6144 quads in the box, counted
    with_patch = estimate(parse_scene(raw), 1.0).elements
    without = estimate(parse_scene(HERTZ), 1.0).elements
    assert 0.9 * 6144 <= with_patch - without <= 1.1 * 6144
