"""Tests of the mesh stage: gmsh builder, .msh reader, cache and config validation."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import gmsh
import numpy as np
import pytest

from app.errors import InputError
from app.mesh.build import build_mesh
from app.mesh.model import Mesh
from app.mesh.read import read_mesh
from app.scene import parse_scene

CONFIGS = Path(__file__).resolve().parents[1] / "configs"


def load(name: str) -> dict:
    with open(CONFIGS / f"{name}.toml", "rb") as f:
        return tomllib.load(f)


@pytest.fixture(scope="module")
def hertz() -> Mesh:
    return build_mesh(parse_scene(load("hertz")))


@pytest.fixture(scope="module")
def patch() -> Mesh:
    return build_mesh(parse_scene(load("patch")))


def quad_areas(m: Mesh) -> np.ndarray:
    """(ne,) shoelace areas."""
    p = m.points[m.quads]
    x, y = p[..., 0], p[..., 1]
    return 0.5 * np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)


def interior_angles(m: Mesh) -> np.ndarray:
    """(ne, 4) signed interior angles in degrees (positive for a counter-clockwise quad)."""
    p = m.points[m.quads]
    a = np.roll(p, 1, axis=1) - p  # to previous corner
    b = np.roll(p, -1, axis=1) - p  # to next corner
    cross = b[..., 0] * a[..., 1] - b[..., 1] * a[..., 0]
    return np.degrees(np.arctan2(cross, np.sum(a * b, axis=2)))


def edge_lengths(m: Mesh, curve: str) -> tuple[np.ndarray, np.ndarray]:
    """Midpoints (k, 2) and lengths (k,) of the edges of a named curve."""
    p = m.points[m.curves[curve]]
    return p.mean(axis=1), np.linalg.norm(p[:, 1] - p[:, 0], axis=1)


def check_valid(m: Mesh, min_angle: float = 15.0) -> None:
    """All-quad, counter-clockwise, decent angles, disjoint bodies, curves on boundaries."""
    assert m.quads.shape == (m.n_elements, 4) and m.points.shape == (m.n_nodes, 2)
    assert np.all(quad_areas(m) > 0)
    ang = interior_angles(m)
    # Delaunay + blossom full-quad recombination keeps angles in (15, 170) degrees;
    # structured grids are checked to be near-rectangular
    max_angle = 180.0 - min_angle if min_angle >= 45.0 else 170.0
    assert ang.min() > min_angle
    assert ang.max() < max_angle
    assert np.all(m.node_body() >= 0)  # no unused node
    assert np.sum(np.abs(ang.sum(axis=1) - 360.0) < 1e-6) == m.n_elements  # convex
    # Bodies share no node.
    sets = [set(np.unique(m.quads[m.body == b]).tolist()) for b in range(len(m.body_names))]
    for i in range(len(sets)):
        for j in range(i + 1, len(sets)):
            assert not sets[i] & sets[j]
    # Every curve edge is a boundary edge (an edge of exactly one quad).
    e = np.sort(np.stack([m.quads, np.roll(m.quads, -1, axis=1)], axis=2).reshape(-1, 2), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    boundary = {tuple(x) for x in uniq[count == 1].tolist()}
    for edges in m.curves.values():
        assert {tuple(x) for x in np.sort(edges, axis=1).tolist()} <= boundary


# ----------------------------------------------------------------------------- scenes


def test_hertz_scene(hertz: Mesh) -> None:
    check_valid(hertz)
    assert hertz.body_names == ["cylinder", "block"]
    assert set(hertz.curves) == {"cyl_arc", "cyl_top", "base", "block_top", "block_sides"}
    assert np.allclose(hertz.points[hertz.curve_nodes("block_top"), 1], 0.0)
    r = np.hypot(*(hertz.points[hertz.curve_nodes("cyl_arc")] - [0.0, 1.0]).T)
    assert np.allclose(r, 1.0)
    nb = hertz.node_body()
    assert np.all(nb[hertz.curve_nodes("cyl_arc")] == 0)
    assert np.all(nb[hertz.curve_nodes("base")] == 1)


def test_hertz_refinement_on_both_sides(hertz: Mesh) -> None:
    for curve in ("block_top", "cyl_arc"):
        mid, length = edge_lengths(hertz, curve)
        near = length[np.hypot(*mid.T) < 0.1]
        far = length[np.abs(mid[:, 0]) > 0.8]
        assert len(near) >= 15, curve
        assert near.max() < 0.02 and far.min() > 10 * near.max(), curve


def test_patch_non_matching(patch: Mesh) -> None:
    check_valid(patch)
    assert patch.body_names == ["lower", "upper"]
    assert patch.n_elements == 8 * 4 + 10 * 5  # structured, sizes 0.25 and 0.2
    xl = np.sort(patch.points[patch.curve_nodes("lower_top"), 0])
    xu = np.sort(patch.points[patch.curve_nodes("upper_bottom"), 0])
    assert np.allclose(xl, np.linspace(0, 2, 9)) and np.allclose(xu, np.linspace(0, 2, 11))
    assert len(np.setdiff1d(np.round(xu, 9), np.round(xl, 9))) > 0
    assert len(patch.curves["lower_sides"]) == 8 and len(patch.curves["upper_sides"]) == 10


def test_two_blocks_config_builds() -> None:
    m = build_mesh(parse_scene(load("two_blocks")))
    assert m.n_elements == 82 and set(m.body_names) == {"lower", "upper"}


def test_cantilever_structured() -> None:
    m = build_mesh(parse_scene(load("cantilever")))
    check_valid(m, min_angle=89.0)
    assert m.n_elements == 80 * 8 and m.n_nodes == 81 * 9
    assert len(m.curves["clamp"]) == 8 and len(m.curves["tip_edge"]) == 8
    assert np.allclose(m.points[m.curve_nodes("clamp"), 0], 0.0)
    assert np.allclose(m.points[m.point_groups["tip"]], [[10.0, 0.0]])


def test_scale_refines() -> None:
    cant = load("cantilever")
    assert build_mesh(parse_scene(cant), scale=0.5).n_elements == 4 * 80 * 8
    cfg = load("hertz")
    scene = parse_scene(cfg)
    n1, n2 = build_mesh(scene).n_elements, build_mesh(scene, scale=0.5).n_elements
    assert 3.0 < n2 / n1 < 5.5


def test_other_shapes_and_named_points() -> None:
    cfg = {
        "mesh": {"size": 0.2},
        "points": {"south": [0.0, -1.0], "mid": [3.3, 0.2], "corner": [2.0, 0.0]},
        "body": [
            {"name": "disk", "shape": {"type": "disk", "center": [0.0, 0.0], "radius": 1.0},
             "curves": {"arc": "rim"}},
            {"name": "tri", "shape": {"type": "polygon",
                                      "points": [[2.0, 0.0], [4.0, 0.0], [3.0, 1.0]]},
             "curves": {"side0": "tri_base", "side1": "tri_slope", "side2": "tri_slope"}},
            {"name": "half", "size": 0.1, "shape": {"type": "half_disk", "center": [0.0, 3.0],
                                                    "radius": 0.5, "side": "right"},
             "curves": {"arc": "half_arc", "flat": "half_flat"}},
        ],
    }
    m = build_mesh(parse_scene(cfg))
    check_valid(m)
    assert m.body_names == ["disk", "tri", "half"]
    for name, xy in cfg["points"].items():
        assert np.allclose(m.points[m.point_groups[name]], [xy])
    assert np.allclose(m.points[m.curve_nodes("half_flat"), 0], 0.0)
    assert np.all(m.points[m.curve_nodes("half_arc"), 0] >= -1e-12)
    area = np.bincount(m.body, quad_areas(m))
    assert area[1] == pytest.approx(1.0) and area[2] == pytest.approx(np.pi / 8, rel=0.02)


def test_refinement_curve_of_other_body() -> None:
    cfg = load("hertz")
    cfg["mesh"]["refine"] = [{"curves": ["cyl_arc"], "size": 0.05, "distance": 0.2}]
    m = build_mesh(parse_scene(cfg))
    check_valid(m)
    mid, length = edge_lengths(m, "block_top")  # refined through cyl_arc's location
    assert length[np.abs(mid[:, 0]) < 0.2].max() < 0.08
    assert length[np.abs(mid[:, 0]) > 2.0].min() > 0.3


# ----------------------------------------------------------------------------- cache


def test_cache_hit_skips_meshing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    cfg = load("hertz")
    first = build_mesh(parse_scene(cfg), cache_dir=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 1

    def no_meshing(*args, **kwargs):
        raise AssertionError("gmsh meshing called on a cache hit")

    monkeypatch.setattr(gmsh.model.mesh, "generate", no_meshing)
    again = build_mesh(parse_scene(copy.deepcopy(cfg)), cache_dir=tmp_path)
    assert again.body_names == first.body_names
    assert np.array_equal(again.points, first.points)
    assert np.array_equal(again.quads, first.quads) and np.array_equal(again.body, first.body)
    assert again.curves.keys() == first.curves.keys()
    for k in first.curves:
        assert np.array_equal(again.curves[k], first.curves[k])
    cfg["body"][0]["E"] = 1.0  # material is not part of the key
    build_mesh(parse_scene(cfg), cache_dir=tmp_path)
    with pytest.raises((AssertionError, InputError), match="cache hit"):
        build_mesh(parse_scene(cfg), scale=0.9, cache_dir=tmp_path)  # other scale: a miss


# ----------------------------------------------------------------------------- reading


def write_msh(path: Path, *, triangles: bool = False, shared: bool = False,
              names: tuple[str, str] = ("left", "right"), version: float = 4.1,
              repeat: bool = False) -> None:
    """Two unit squares side by side [0,1]x[0,1] and [1,2]x[0,1], 2x2 quads each
    (`repeat`: the group 'floor' lists its first curve twice, the first body its surface)."""
    gmsh.initialize([], readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("w")
        geo = gmsh.model.geo
        surfs, lines = [], []
        shared_pts: list[int] = []
        for k in range(2):
            xs = [(k, 0), (k + 1, 0), (k + 1, 1), (k, 1)]
            if shared and k == 1:
                p = [shared_pts[1]] + [geo.addPoint(x, y, 0) for x, y in xs[1:3]] + [shared_pts[2]]
            else:
                p = [geo.addPoint(x, y, 0) for x, y in xs]
            shared_pts = p
            ls = [geo.addLine(p[i], p[(i + 1) % 4]) for i in range(4)]
            if shared and k == 1:
                ls[3] = -lines[0][1]
            lines.append(ls)
            surfs.append(geo.addPlaneSurface([geo.addCurveLoop(ls)]))
            for c in ls:
                geo.mesh.setTransfiniteCurve(abs(c), 3)
            geo.mesh.setTransfiniteSurface(surfs[-1])
            if not triangles:
                geo.mesh.setRecombine(2, surfs[-1])
        geo.synchronize()
        for k, (name, s) in enumerate(zip(names, surfs, strict=True)):
            gmsh.model.addPhysicalGroup(2, [s] * (1 + (repeat and k == 0)), name=name)
        gmsh.model.addPhysicalGroup(1, [lines[0][0], lines[1][0]] + [lines[0][0]] * repeat,
                                    name="floor")
        gmsh.model.addPhysicalGroup(1, [lines[0][0]], name="left_floor")
        gmsh.model.addPhysicalGroup(0, [1], name="origin")
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", version)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.mark.parametrize("version", [4.1, 2.2])
def test_read_round_trip(tmp_path: Path, version: float) -> None:
    path = tmp_path / "two.msh"
    write_msh(path, version=version)
    m = read_mesh(path, ["right", "left"])
    check_valid(m, min_angle=89.0)
    assert m.body_names == ["right", "left"] and m.n_elements == 8 and m.n_nodes == 18
    assert np.all(m.points[m.quads[m.body == 0]][..., 0] >= 1.0)
    assert set(m.curves) == {"floor", "left_floor"}
    assert len(m.curves["floor"]) == 4 and len(m.curves["left_floor"]) == 2
    assert np.allclose(m.points[m.curve_nodes("floor"), 1], 0.0)
    assert np.allclose(m.points[m.point_groups["origin"]], [[0.0, 0.0]])


@pytest.mark.parametrize("version", [4.1, 2.2])
def test_a_group_listing_an_entity_twice_has_each_element_once(tmp_path: Path,
                                                               version: float) -> None:
    """MSH 2.2 writes the elements of an entity listed twice in a physical group twice:
    before, 'floor' had 6 edges, and a load on it counted the repeated ones twice (a
    traction on such a curve gave 4x the strain energy); the body 'left' had 8 quads, 4
    of them twice, and twice their stiffness."""
    path = tmp_path / "two.msh"
    write_msh(path, version=version, repeat=True)
    m = read_mesh(path, ["right", "left"])
    assert len(m.curves["floor"]) == 4
    assert len(np.unique(np.sort(m.curves["floor"], axis=1), axis=0)) == 4
    assert m.n_elements == 8 and np.count_nonzero(m.body == 1) == 4
    check_valid(m, min_angle=89.0)


@pytest.mark.parametrize("key, value", [
    ("refine", [{"points": [[0.0, 0.0]], "size": 0.01, "distance": 0.1}]),
    ("patch", [{"box": [0.0, 0.0, 0.5, 0.5], "size": 0.1}]),
    ("algorithm", "frontal-quad"),
])
def test_gmsh_keys_with_a_mesh_file_are_an_error(key: str, value) -> None:
    """Before: ignored without a word (punch.toml ran the same mesh)."""
    cfg = {"mesh": {"file": "two.msh", key: value}, "body": [{"name": "left"}]}
    with pytest.raises(InputError, match=f"mesh.{key} does not apply to a mesh read from "
                                         "mesh.file \\(two.msh\\)"):
        parse_scene(cfg)


@pytest.mark.parametrize("key, value", [
    ("shape", {"type": "rectangle", "origin": [0.0, 0.0], "width": 3.0, "height": 1.0}),
    ("curves", {"bottom": "floor"}),
])
def test_body_geometry_with_a_mesh_file_is_an_error(key: str, value) -> None:
    """Before: ignored without a word: a config whose [body.shape] (width 3 here) or
    [body.curves] differed from the .msh ran the file's mesh, as if they applied."""
    cfg = {"mesh": {"file": "two.msh"}, "body": [{"name": "left", key: value}]}
    with pytest.raises(InputError, match=f"body 'left': {key} does not apply to a mesh read "
                                         "from mesh.file"):
        parse_scene(cfg)


def test_build_mesh_reads_file(tmp_path: Path) -> None:
    write_msh(tmp_path / "two.msh")
    cfg = {"mesh": {"file": "two.msh"}, "points": {"corner": [2.0, 1.0]},
           "body": [{"name": "left"}, {"name": "right"}]}
    m = build_mesh(parse_scene(cfg), base_dir=tmp_path)
    assert m.n_elements == 8 and np.allclose(m.points[m.point_groups["corner"]], [[2, 1]])


def test_read_errors(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="nowhere.msh not found"):
        read_mesh(tmp_path / "nowhere.msh", ["a"])
    (tmp_path / "junk.msh").write_text("not a mesh\n")
    with pytest.raises(InputError, match="junk.msh"):
        read_mesh(tmp_path / "junk.msh", ["a"])
    tri = tmp_path / "tri.msh"
    write_msh(tri, triangles=True)
    with pytest.raises(InputError, match=r"tri\.msh has 16 triangles: only quadrilaterals"):
        read_mesh(tri, ["left", "right"])
    ok = tmp_path / "ok.msh"
    write_msh(ok)
    with pytest.raises(InputError, match="physical surface 'right' is not a \\[\\[body\\]\\]"):
        read_mesh(ok, ["left", "other"])
    with pytest.raises(InputError, match="no physical surface for body 'third'"):
        read_mesh(ok, ["left", "right", "third"])
    shared = tmp_path / "shared.msh"
    write_msh(shared, shared=True)
    with pytest.raises(InputError, match="bodies 'left' and 'right' share nodes"):
        read_mesh(shared, ["left", "right"])


# ----------------------------------------------------------------------------- config errors


def hertz_with(change) -> dict:
    cfg = load("hertz")
    change(cfg)
    return cfg


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda c: c["body"][1]["shape"].update(width=-1.0),
         "body 'block': shape.width must be a number > 0"),
        (lambda c: c["body"][1]["shape"].pop("height"), "body 'block': shape.height is missing"),
        (lambda c: c["body"][1]["shape"].update(width="8"), "body 'block': shape.width must be"),
        (lambda c: c["body"][0]["shape"].update(type="ellipse"),
         "body 'cylinder': shape.type must be one of"),
        (lambda c: c["body"][0]["shape"].update(side="down"), "body 'cylinder': shape.side"),
        (lambda c: c["body"][1]["shape"].update(widht=8.0),
         "body 'block': shape.widht is not a key of a rectangle"),
        (lambda c: c["body"][0]["shape"].update(structured=True),
         "body 'cylinder': shape.structured is only supported for type = \"rectangle\""),
        (lambda c: c["body"][0]["curves"].update(top="x"), "body 'cylinder': curves.top is not"),
        (lambda c: c["body"][0]["curves"].update(flat="base"),
         "curve name 'base' is used by bodies 'cylinder' and 'block'"),
        (lambda c: c["body"][1].update(name="cylinder"), "body name 'cylinder' is used twice"),
        (lambda c: c["mesh"].update(size=0), "mesh.size must be a number > 0"),
        (lambda c: c.pop("mesh"), r"\[mesh\] section is missing"),
        (lambda c: c["mesh"]["refine"][0].update(size=-0.1), r"mesh.refine\[0\].size must be"),
        (lambda c: c["mesh"]["refine"][0].update(curves=["nope"]),
         r"mesh.refine\[0\].curves: unknown curve 'nope'"),
        (lambda c: c.update(points={"p": [0.5, 0.5, 0.0]}), r"points.p must be a point \[x, y\]"),
        (lambda c: c.update(points={"p": [9.0, 9.0]}), "points.p = \\[9, 9\\] is"),
    ],
)
def test_config_errors(change, message: str) -> None:
    with pytest.raises(InputError, match=message):
        build_mesh(parse_scene(hertz_with(change)))


def test_named_point_off_structured_grid() -> None:
    cfg = load("cantilever")
    cfg["points"]["inner"] = [5.0, 0.03]  # inside a structured body, not on a grid node
    with pytest.raises(InputError, match="points.inner = \\[5, 0.03\\] is 0.03 away"):
        build_mesh(parse_scene(cfg))


def test_polygon_clockwise_error() -> None:
    cfg = {"mesh": {"size": 0.5}, "body": [
        {"name": "p", "shape": {"type": "polygon", "points": [[0, 0], [0, 1], [1, 0]]}}]}
    with pytest.raises(InputError, match="body 'p': shape.points must be counter-clockwise"):
        build_mesh(parse_scene(cfg))


def test_caller_gmsh_session_kept() -> None:
    gmsh.initialize([], readConfigFiles=False, interruptible=False)
    try:
        build_mesh(parse_scene(load("patch")))
        assert gmsh.isInitialized()
    finally:
        gmsh.finalize()


def test_refinement_curve_split_over_sides() -> None:
    cfg = load("hertz")  # block_sides = left and right sides of the block: two separate pieces
    cfg["mesh"]["refine"] = [{"curves": ["block_sides"], "size": 0.1, "distance": 0.5, "flat": 2.9}]
    m = build_mesh(parse_scene(cfg))
    check_valid(m)
    mid, length = edge_lengths(m, "base")  # own curve
    assert length[np.abs(mid[:, 0]) > 1.2].max() < 0.15
    assert length[np.abs(mid[:, 0]) < 0.5].min() > 0.3
    mid, length = edge_lengths(m, "cyl_arc")  # other body: refined near both ends x = -1, 1
    for end in (-1.0, 1.0):
        assert length[np.abs(mid[:, 0] - end) < 0.1].max() < 0.25
    assert length[np.abs(mid[:, 0]) < 0.3].min() > 0.3


@pytest.mark.parametrize("points, sides", [
    ([[0, 0], [3, 0], [0, 1], [3, 1.5], [2, 2]], "side1 and side4"),  # bow tie, area > 0
    ([[0, 0], [2, 1], [2, 0], [0, 1], [-1, 0.5]], "side0 and side2"),
    ([[0, 0], [2, 0], [1, 0], [2, 0], [2, 1], [0, 1]], "side0 and side1"),  # folds back
    ([[0, 0], [2, 0], [2, 1], [1, 0], [0, 1]], "side0 and side2"),  # touches a side
])
def test_polygon_self_intersecting_error(points, sides: str) -> None:
    """A crossing, touching or back-tracking outline is a one-line error (before: gmsh
    meshed it into no quads and the builder failed with a ValueError traceback)."""
    cfg = {"mesh": {"size": 0.2}, "body": [
        {"name": "p", "shape": {"type": "polygon", "points": points}}]}
    with pytest.raises(InputError, match=f"body 'p': shape.points: {sides} cross or overlap"):
        build_mesh(parse_scene(cfg))


def test_polygon_simple_nonconvex_meshes() -> None:
    cfg = {"mesh": {"size": 0.2}, "body": [{"name": "p", "shape": {
        "type": "polygon", "points": [[0, 0], [2, 0], [2, 2], [1, 0.5], [0, 2]]}}]}
    m = build_mesh(parse_scene(cfg))
    assert m.n_elements > 0


@pytest.mark.parametrize("height", [0.15, 0.05, 1e-3])
def test_a_layer_thinner_than_the_element_size_meshes(height: float) -> None:
    """A 2 x height polygon at size 0.2: before, `gmsh could not mesh it: 1D mesh cannot
    be divided by 2` (the full-quad recipe meshes at twice the size)."""
    cfg = {"mesh": {"size": 0.2}, "body": [{"name": "p", "shape": {
        "type": "polygon", "points": [[0, 0], [2, 0], [2, height], [0, height]]},
        "curves": {"side0": "base"}}]}
    m = build_mesh(parse_scene(cfg))
    check_valid(m, min_angle=45.0)
    assert m.n_elements == 20 and len(m.curves["base"]) == 10
    assert quad_areas(m).sum() == pytest.approx(2 * height, rel=1e-12)


def test_hertz_at_an_element_size_above_the_bodies_meshes() -> None:
    m = build_mesh(parse_scene(load("hertz")), scale=20.0)  # size 10 > the 8 x 4 block
    check_valid(m)
    assert set(m.body) == {0, 1}


@pytest.mark.parametrize("y", [0.05, 0.03, 0.01, 1e-5])
def test_a_named_point_near_a_side_meshes_without_folds(y: float) -> None:
    """A point y above the base of a 2 x 1 polygon at size 0.2: before, gmsh's quads
    folded over each other (6 edges run twice, total area 2.03-2.06), which ran silently
    (app/mesh/folds.py now refuses it)."""
    from app.mesh.checks import check_scene
    from app.scene.geometry import polygon_areas

    cfg = {"mesh": {"size": 0.2}, "points": {"m": [0.55, y]}, "body": [{"name": "p", "shape": {
        "type": "polygon", "points": [[0, 0], [2, 0], [2, 1], [0, 1]]}}]}
    m = build_mesh(parse_scene(cfg))
    check_scene(m, [])
    assert polygon_areas(m.points[m.quads]).sum() == pytest.approx(2.0, rel=1e-12)
    np.testing.assert_allclose(m.points[m.point_groups["m"]], [[0.55, y]])


def test_cache_keys_change_only_for_scenes_with_interior_named_points(tmp_path: Path) -> None:
    """The near-point size fields (app/mesh/near_points.py) change only meshes with named
    points inside a body: their keys change, every other cached mesh stays valid."""
    from app.mesh.cache import cache_key

    def plain_key(scene) -> str:
        return cache_key(scene.source | {"scale": 1.0, "gmsh": gmsh.__version__,
                                         "algorithm": scene.algorithm})

    scene = parse_scene(load("patch"))
    build_mesh(scene, cache_dir=tmp_path / "a")
    assert (tmp_path / "a" / f"mesh-{plain_key(scene)}.npz").exists()
    cfg = {"mesh": {"size": 0.2}, "points": {"m": [0.55, 0.01]}, "body": [{"name": "p",
           "shape": {"type": "polygon", "points": [[0, 0], [2, 0], [2, 1], [0, 1]]}}]}
    scene = parse_scene(cfg)
    build_mesh(scene, cache_dir=tmp_path / "b")
    files = list((tmp_path / "b").glob("mesh-*.npz"))
    assert len(files) == 1 and files[0].name != f"mesh-{plain_key(scene)}.npz"


@pytest.mark.parametrize("shift", [(1e6, 3e5), (1e8, 3e7), (-1e8, 3e7)])
def test_polygon_areas_do_not_depend_on_the_position(shift) -> None:
    """A square of side 0.125 and a thin quad, moved by 1e8: the shoelace sums
    x_i y_(i+1) - x_(i+1) y_i of absolute coordinates carried the round-off of |x|^2
    (3e15 x eps ~ 0.7, above the area): the moved elements read inverted or degenerate
    (`check_elements`: scripts/check_invariance.py ... --xf shift=1e8:3e7 failed) and
    `orient_boundary_edges` flipped a master curve (node-to-segment gaps of the wrong
    sign). Formed relative to the first vertex, they equal the unmoved areas."""
    from app.scene.geometry import polygon_areas

    quads = np.array([[[0, 0], [0.125, 0], [0.125, 0.125], [0, 0.125]],
                      [[0, 0], [1, 0], [1, 1 / 1024], [0, 1 / 1024]]], dtype=float)
    moved = quads + np.asarray(shift)
    assert np.array_equal(moved - np.asarray(shift), quads)  # exact: the same geometry
    np.testing.assert_allclose(polygon_areas(moved), [1 / 64, 1 / 1024], rtol=1e-15)
    np.testing.assert_allclose(polygon_areas(moved[:, ::-1]), [-1 / 64, -1 / 1024],
                               rtol=1e-15)
