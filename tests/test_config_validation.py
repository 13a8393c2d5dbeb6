"""Input checked before the work starts: unknown keys, inconsistent scenes, sizes the
machine cannot hold, degenerate and overlapping meshes."""

from __future__ import annotations

import copy
import time
import tomllib

import numpy as np
import pytest
from support import CONFIGS

from app.config import parse_config
from app.config_keys import ALLOWED_KEYS, check_keys
from app.errors import InputError
from app.mesh.checks import check_interface_bodies, check_overlaps, check_quads
from app.mesh.estimate import check_size, estimate, machine_memory
from app.mesh.model import Mesh
from app.scene import parse_scene

PATCH = tomllib.loads((CONFIGS / "patch.toml").read_text())
HERTZ = tomllib.loads((CONFIGS / "hertz.toml").read_text())


def _with(raw: dict, path: tuple, value) -> dict:
    out = copy.deepcopy(raw)
    node = out
    for key in path[:-1]:
        node = node.setdefault(key, {}) if isinstance(node, dict) else node[key]
    node[path[-1]] = value
    return out


def _error(raw: dict) -> str:
    with pytest.raises(InputError) as info:
        parse_config(raw)
    msg = str(info.value)
    assert "\n" not in msg
    return msg


@pytest.mark.parametrize(("path", "value", "needle"), [
    (("analysis", "sdd"), 16, "did you mean analysis.sd?"),
    (("analysis", "warmstart"), False, "did you mean analysis.warm_start?"),
    (("analysis", "Steps"), 2, "did you mean analysis.steps?"),
    (("analysis", "thicknes"), 1.0, "did you mean analysis.thickness?"),
    (("mesh", "sise"), 0.1, "did you mean mesh.size?"),
    (("mesh", "refine"), [{"points": [[0.0, 0.0]], "size": 0.1, "distance": 1.0,
                           "flatt": 0.1}], "did you mean mesh.refine[0].flat?"),
    (("body", 0, "young"), 5.0, "unknown key 'young'"),
    (("body", 0, "e"), 5.0, "did you mean E?"),
    (("body", 1, "body_forces"), [0.0, 1.0], "did you mean body_force?"),
    (("support", 0, "uz"), 0.0, "did you mean u"),
    (("load", 0, "presure"), 1.0, "did you mean pressure?"),
    (("interface", 0, "muu"), 0.1, "did you mean mu?"),
    (("interface", 0, "search_dist"), 0.1, "did you mean search_distance?"),
    (("reference", "radius_"), 1.0, "did you mean reference.radius?"),
    (("analysiss",), {}, "did you mean analysis?"),
    (("interfaces",), [], "did you mean interface?"),
])
def test_unknown_keys_are_errors_with_a_suggestion(path, value, needle):
    msg = _error(_with(PATCH, path, value))
    assert "unknown key" in msg and needle in msg and "allowed keys:" in msg, msg
    if path[0] in ("analysis", "mesh", "reference"):
        assert f"unknown key {path[0]}." in msg and f"mean {path[0]}." in msg, msg


@pytest.mark.parametrize("table", sorted(ALLOWED_KEYS))
def test_every_allowed_key_passes_the_key_check(table):
    check_keys(dict.fromkeys(ALLOWED_KEYS[table], 0), table, table)
    with pytest.raises(InputError, match="unknown key 'no_such_key'"):
        check_keys({"no_such_key": 0}, table, table)


def test_interface_accepts_discretisation_key():
    assert "discretisation" in ALLOWED_KEYS["interface"]
    parse_config(_with(PATCH, ("interface", 0, "discretisation"), "node-to-segment"))


@pytest.mark.parametrize(("path", "value", "needle"), [
    (("analysis", "warm_start"), "no", "warm_start must be true or false"),
    (("analysis", "compliance"), "fast", "analysis.compliance"),
    (("analysis", "steps"), 10**10, "analysis.steps = 10000000000 is above"),
    (("parameters", "x"), 1.0, "parameters.x: the name is reserved"),
    (("parameters", "y"), 1.0, "parameters.y"),
    (("parameters", "sqrt"), 1.0, "parameters.sqrt"),
    (("parameters", "pi"), 3.0, "parameters.pi"),
    (("interface", 0, "master"), "upper_top", "both curves of body 'upper'"),
    (("reference",), {"type": "hertzz", "radius": 1.0}, "did you mean hertz?"),
    (("reference",), {"radius": 1.0}, "reference.type = None"),
    (("interface", 0, "name"), 5, "name must be a non-empty string"),
    (("interface", 0, "name"), "", "name must be a non-empty string"),
    (("mesh", "refine"), [{"points": [[0.0, 0.0]], "size": 0.1, "distance": 0.1,
                           "flat": 0.5}], "flat = 0.5 is larger than distance = 0.1"),
])
def test_inconsistent_values_are_errors(path, value, needle):
    assert needle in _error(_with(PATCH, path, value))


def test_two_interfaces_with_the_same_name_are_an_error():
    raw = copy.deepcopy(HERTZ)
    raw["interface"].append(dict(raw["interface"][0]))
    assert "is used twice" in _error(raw)


# ----------------------------------------------------------------------------- sizes


@pytest.mark.parametrize("name", ["cantilever", "hertz", "patch", "multibody", "cattaneo",
                                  "hard/hertz_incompressible", "hard/aspect_ratio",
                                  "hertz_patch"])
def test_size_estimate_is_within_a_factor_two(name):
    from app.mesh.build import build_mesh

    raw = tomllib.loads((CONFIGS / f"{name}.toml").read_text())
    est = estimate(parse_scene(raw), 1.0)
    mesh = build_mesh(parse_scene(raw), 1.0)
    print(f"{name}: estimated {est.elements:.0f} elements, built {mesh.n_elements} "
          f"(ratio {est.elements / mesh.n_elements:.2f})")
    assert 0.5 <= est.elements / mesh.n_elements <= 2.0, (est.elements, mesh.n_elements)
    assert est.dofs == pytest.approx(2 * est.elements)


def test_too_large_a_mesh_is_refused_quickly_and_allow_large_overrides():
    t0 = time.perf_counter()
    with pytest.raises(InputError) as info:
        check_size(parse_scene(PATCH), 1e-4 / PATCH["mesh"]["size"])
    assert time.perf_counter() - t0 < 1.0
    msg = str(info.value)
    assert "elements" in msg and "DOFs" in msg and "GB" in msg and "--allow-large" in msg
    est = check_size(parse_scene(PATCH), 1e-4 / PATCH["mesh"]["size"], allow_large=True)
    assert est.memory > machine_memory()
    assert check_size(parse_scene(PATCH), 1.0).elements == pytest.approx(82)



@pytest.mark.parametrize("scale", [1e-200, 1e-320, 0.0, 2.0**-1999])
@pytest.mark.parametrize("raw", [PATCH, HERTZ], ids=["structured", "refined"])
def test_underflowing_sizes_are_refused_not_a_traceback(raw, scale):
    with pytest.raises(InputError, match="unbounded|more than this machine"):
        check_size(parse_scene(raw), scale)


def test_splits_of_a_mesh_file_count_in_the_estimate():
    """`run meshes/punch.toml --refine 8`: before, no estimate for a mesh.file, and the run
    went on to split 1348 quads into 8.8e7."""
    punch = CONFIGS.parent / "meshes" / "punch.toml"
    scene = parse_scene(tomllib.loads(punch.read_text()))
    unsplit = check_size(scene, base_dir=punch.parent)  # read, for the disk check
    assert unsplit.elements == 1348 and unsplit.dofs == 2924  # two DOFs per node
    assert check_size(scene, base_dir=punch.parent, refine=1).elements == 4 * 1348
    with pytest.raises(InputError, match="about 8.8e\\+07 elements.*use fewer splits"):
        check_size(scene, base_dir=punch.parent, refine=8)


def test_structured_divisions_count_in_the_estimate():
    raw = _with(PATCH, ("body", 0, "shape", "divisions"), [100000, 100000])
    with pytest.raises(InputError, match="about 1e\\+10 elements"):
        check_size(parse_scene(raw), 1.0)


# ----------------------------------------------------------------------------- meshes


def _mesh(points, quads, body=None, names=("a",), curves=None) -> Mesh:
    quads = np.asarray(quads, dtype=np.int64)
    body = np.zeros(len(quads), np.int64) if body is None else np.asarray(body)
    return Mesh(np.asarray(points, float), quads, body, list(names), curves or {})


SQUARE = [[0, 0], [1, 0], [1, 1], [0, 1]]


@pytest.mark.parametrize(("points", "quad", "needle"), [
    (SQUARE, [0, 1, 2, 2], "repeats a node"),
    (SQUARE + [[1, 0]], [0, 1, 4, 2], "corner angle"),  # zero-length edge
    ([[0, 0], [1, 0], [2, 0], [0, 1]], [0, 1, 2, 3], "corner angle"),  # 180-degree corner
    ([[0, 0], [2, 0], [0.5, 0.5], [0, 2]], [0, 1, 2, 3], "corner angle"),  # non-convex
    ([[0, 0], [1, 1], [1, 0], [0, 1]], [0, 1, 2, 3], "corner angle"),  # bow-tie
])
def test_degenerate_quads_are_errors(points, quad, needle):
    good = np.array(SQUARE, float) + [5.0, 0.0]  # a good element beside the bad one
    pts = np.vstack([points, good])
    off = len(points)
    quads = [quad, [off, off + 1, off + 2, off + 3]]
    with pytest.raises(InputError) as info:
        check_quads(_mesh(pts, quads))
    assert needle in str(info.value) and "body 'a'" in str(info.value)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -1e31])
def test_non_finite_or_huge_coordinates_are_errors(bad):
    pts = np.array(SQUARE, float)
    pts[2, 1] = bad
    with pytest.raises(InputError, match="non-finite or huge coordinates"):
        check_quads(_mesh(pts, [[0, 1, 2, 3]]))


def test_good_quads_pass():
    check_quads(_mesh([[0, 0], [1, 0], [1.2, 1], [0, 0.8]], [[0, 1, 2, 3]]))


def _two_blocks(shift: float) -> Mesh:
    pts = np.array(SQUARE + [[x, y + shift] for x, y in SQUARE], float)
    return _mesh(pts, [[0, 1, 2, 3], [4, 5, 6, 7]], [0, 1], ("lower", "upper"),
                 {"lower_top": np.array([[2, 3]]), "upper_bottom": np.array([[4, 5]]),
                  "lower_base": np.array([[0, 1]])})


class _It:
    def __init__(self, slave, master):
        self.name, self.slave, self.master = "contact", slave, master


def test_overlapping_bodies_need_an_interface():
    with pytest.raises(InputError, match="'upper' and 'lower' overlap|'lower' and 'upper' "
                       "overlap"):
        check_overlaps(_two_blocks(0.3), [])
    check_overlaps(_two_blocks(0.3), [_It("upper_bottom", "lower_top")])  # a fit
    check_overlaps(_two_blocks(1.0), [])  # touching only
    check_overlaps(_two_blocks(1.5), [])


@pytest.mark.parametrize("top", [0.95, 0.998])
def test_a_thin_overlap_is_refused_after_meshing(top):
    """The upper block of patch.toml 0.05 or 0.002 into the lower (elements 0.2, 0.25):
    before, no element centre lay in the other body and the run went on with the bodies
    passing through each other. Side by side (touching) they pass."""
    from app.run import RunOptions, build_scene_mesh

    raw = _with(PATCH, ("body", 1, "shape", "origin"), [0.0, top])
    del raw["interface"]
    with pytest.raises(InputError, match="overlap .* no \\[\\[interface\\]\\] joins them"):
        build_scene_mesh(parse_config(raw, CONFIGS / "patch.toml"), RunOptions())
    raw = _with(PATCH, ("body", 1, "shape", "origin"), [0.0, 1.0])
    del raw["interface"]
    build_scene_mesh(parse_config(raw, CONFIGS / "patch.toml"), RunOptions())


def test_interface_on_one_body_is_an_error_for_read_meshes():
    with pytest.raises(InputError, match="both on body 'lower'"):
        check_interface_bodies(_two_blocks(1.0), [_It("lower_base", "lower_top")])
    check_interface_bodies(_two_blocks(1.0), [_It("upper_bottom", "lower_top")])


def test_overlapping_bodies_in_a_scene_are_refused_after_meshing():
    from app.run import RunOptions, build_scene_mesh

    raw = _with(PATCH, ("body", 1, "shape", "origin"), [0.5, 0.5])
    del raw["interface"]
    with pytest.raises(InputError, match="overlap .* no \\[\\[interface\\]\\] joins them"):
        build_scene_mesh(parse_config(raw, CONFIGS / "patch.toml"), RunOptions())
    raw = _with(PATCH, ("body", 1, "shape", "origin"), [2.0, 0.0])  # side by side
    del raw["interface"]
    build_scene_mesh(parse_config(raw, CONFIGS / "patch.toml"), RunOptions())


@pytest.mark.parametrize(("path", "value", "needle"), [
    (("body", 0, "shape", "widht"), 2.0, "did you mean width?"),
    (("body", 0, "shape", "orign"), [0.0, 0.0], "did you mean origin?"),
    (("body", 0, "curves", "tpo"), "x", "did you mean top?"),
])
def test_shape_keys_and_sides_suggest_the_closest(path, value, needle):
    from app.scene import parse_scene

    with pytest.raises(InputError, match=needle.replace("?", "\\?")):
        parse_scene(_with(PATCH, path, value))


@pytest.mark.parametrize(("key", "value"), [("width", 2.5e-231), ("height", 1e-12)])
def test_degenerate_shapes_are_errors(key, value):
    from app.scene import parse_scene

    with pytest.raises(InputError, match="shape is degenerate"):
        parse_scene(_with(PATCH, ("body", 0, "shape", key), value))


@pytest.mark.parametrize(("path", "value", "needle"), [
    (("body", 1, "name"), True, "body #2: name must be a non-empty string (got True)"),
    (("body", 0, "name"), "", "body #1: name must be a non-empty string (got '')"),
    (("support", 0, "on"), 2, "support #1: on must be a curve or point group name (got 2)"),
    (("load", 0, "on"), ["upper_top"], "load #1: on must be a curve name (got ['upper_top'])"),
    (("interface", 0, "master"), 1e12, "master must be a curve name (got 1000000000000.0)"),
])
def test_a_name_of_the_wrong_type_is_not_reported_missing(path, value, needle):
    """Before: `support #1: missing key on (...)` for `on = 2` (scripts/fuzz_inputs.py)."""
    msg = _error(_with(PATCH, path, value))
    assert needle in msg and "missing" not in msg, msg
    del_raw = copy.deepcopy(PATCH)
    del del_raw[path[0]][path[1]][path[2]]
    assert f"missing key {path[2]}" in _error(del_raw)


def test_a_mesh_far_from_the_origin_is_not_degenerate():
    """Element areas are taken about each element's first corner: with the shoelace of
    absolute coordinates a 0.2 square at (1e8, 3e7) read 12.5 times its area (0.46 at
    1e7, 5e-4 at 1e6), and a valid mesh moved there (a .msh in projected map
    coordinates) stopped with `inverted or degenerate`; smaller ones flipped no sign but
    the area was wrong."""
    from app.discretisation.bulk import check_elements
    from app.mesh.model import orient_ccw
    from app.scene.geometry import polygon_areas

    xs = np.linspace(0.0, 1.0, 6)
    pts = np.array([[x, y] for y in xs for x in xs]) + [1e8, 3e7]
    idx = np.arange(36).reshape(6, 6)
    quads = np.column_stack([idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(),
                             idx[1:, 1:].ravel(), idx[1:, :-1].ravel()])
    np.testing.assert_allclose(polygon_areas(pts[quads]), 0.04, rtol=1e-7)
    np.testing.assert_array_equal(orient_ccw(pts, quads), quads)
    np.testing.assert_array_equal(orient_ccw(pts, quads[:, ::-1]), quads)
    check_elements(_mesh(pts, quads))
