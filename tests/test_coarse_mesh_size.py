"""A mesh size too large for the scene. Before, `--mesh-size 1e300` on hertz.toml ran a
7-element mesh (2 contact pairs, p_max 90% off Hertz's, contact width 0) and completed
without a word: now an arc that no element size resolves is an error naming the body and
the largest size that resolves it; straight bodies meshed with gmsh's fewest elements (a
coarse mesh may be meant) get a warning."""

from __future__ import annotations

import tomllib

import pytest
from support import CONFIGS, read_summary, run_cli

from app.config import load_config
from app.errors import InputError
from app.mesh.estimate import check_resolution, one_element_bodies
from app.scene import parse_scene

HERTZ = parse_scene(tomllib.loads((CONFIGS / "hertz.toml").read_text()))
SHIPPED = sorted([*CONFIGS.glob("*.toml"), *(CONFIGS / "hard").glob("*.toml")])


def test_an_arc_no_size_resolves_is_an_error_with_the_largest_size_that_does():
    # hertz: mesh.size 0.5, refinement 0.01 on the contact, the cylinder's radius 1:
    # --mesh-size H scales both by H / 0.5, so H = 50 puts 1.0 on the arc
    with pytest.raises(InputError, match=r"^--mesh-size 1e\+300 leaves body 'cylinder' "
                       r"unresolved: .* more than its arc's radius 1, .* at most 50$"):
        check_resolution(HERTZ, 2e300, given=1e300)
    with pytest.raises(InputError, match="at most 50"):
        check_resolution(HERTZ, 200.0, given=100.0)
    check_resolution(HERTZ, 100.0, given=50.0)  # 1.0 on the arc: the largest accepted
    check_resolution(HERTZ, 200.0 * 2.0**-1, given=100.0)  # --refine 1: splits follow arcs


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_shipped_scenes_at_8_times_their_size_pass_without_a_warning(path):
    """(README's rank hunt runs every scene at 4x and 8x its mesh.size.)"""
    cfg = load_config(path, [])
    check_resolution(cfg.scene, 8.0)
    assert one_element_bodies(cfg.scene, 8.0) == []


def test_straight_bodies_beyond_their_size_are_a_warning():
    cfg = load_config(CONFIGS / "hard" / "stack_slip.toml", [])
    scale = 1e300 / cfg.mesh_size  # --mesh-size 1e300
    check_resolution(cfg.scene, scale)  # no arc: the geometry is exact at any size
    warned = one_element_bodies(cfg.scene, scale)
    assert len(warned) == 4 and warned[0].startswith("body 'foundation': its smallest "
                                                     "element size 1e+300 is larger than "
                                                     "the body (4 across)")


def test_the_run_fails_with_one_error_line_and_a_failed_summary(tmp_path):
    res = run_cli(["run", str(CONFIGS / "hertz.toml"), "--out", str(tmp_path), "--quiet",
                   "--mesh-size", "1e300"])
    assert res.returncode == 2, res.stderr
    errors = [ln for ln in res.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "body 'cylinder'" in errors[0] and "at most 50" in errors[0]
    assert "Traceback" not in res.stderr and read_summary(tmp_path)["status"] == "failed"
