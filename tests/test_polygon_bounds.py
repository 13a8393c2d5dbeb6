"""A polygon's corners and the refinement zones cannot exhaust the machine before the
size check (app/scene/shapes/polygon_simple.py, app/scene/shapes/polygon.py,
app/scene/parse.py).

Before, the self-intersection test built every one of the n^2 / 2 side pairs at once:
486 MB at 2000 corners (traced by tracemalloc), 1.1 GB and 11 s at 3000 (RSS), and a
15,000-corner `shape.points` in a config would have needed more memory than the machine's
25 GB, all before the mesh-size estimate. It now tests at most PAIRS_PER_BLOCK pairs at
once, and a polygon has at most MAX_POINTS corners.
"""

import math
import tracemalloc

import numpy as np
import pytest
from support import CONFIGS

from app.config import load_config
from app.errors import InputError
from app.mesh.build import build_mesh
from app.scene import parse_scene
from app.scene.shapes import polygon_simple
from app.scene.shapes.polygon import MAX_POINTS


def _circle(n: int) -> np.ndarray:
    t = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    return np.c_[np.cos(t), np.sin(t)]


def test_the_crossing_test_memory_does_not_grow_with_the_pairs() -> None:
    tracemalloc.start()
    try:
        assert polygon_simple.crossing_sides(_circle(2000)) is None
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 150e6, peak  # 486 MB before


def test_blocks_find_the_same_first_pair_as_all_pairs(monkeypatch) -> None:
    """Blocks of 7 pairs against one block of every pair, on random outlines."""
    rng = np.random.default_rng(3)
    cases = [rng.random((int(rng.integers(3, 12)), 2)) for _ in range(150)]
    cases += [_circle(9), _circle(9)[[0, 1, 2, 3, 5, 4, 6, 7, 8]]]
    whole = [polygon_simple.crossing_sides(p) for p in cases]
    assert any(w is None for w in whole) and any(w is not None for w in whole)
    monkeypatch.setattr(polygon_simple, "PAIRS_PER_BLOCK", 7)
    assert [polygon_simple.crossing_sides(p) for p in cases] == whole


def test_too_many_corners_is_one_line() -> None:
    pts = (0.5 * _circle(MAX_POINTS + 1)).tolist()
    cfg = {"mesh": {"size": 0.2}, "body": [
        {"name": "p", "shape": {"type": "polygon", "points": pts}}]}
    with pytest.raises(InputError, match=r"body 'p': shape.points has 10001 points, more "
                                         r"than 10000"):
        build_mesh(parse_scene(cfg))


@pytest.mark.parametrize("kind, entry", [
    ("refine", {"points": [[0.5, 0.5]], "size": 0.1, "distance": 0.0, "flat": 0.0}),
    ("patch", {"box": [0.0, 0.0, 0.5, 0.5], "size": 0.1}),
])
def test_too_many_refinement_zones_is_one_line(kind, entry) -> None:
    """Before: 5000 [[mesh.refine]] entries meshed patch.toml in 17.6 s, 10,000 in 88 s
    (gmsh's time to add a field grows with the fields), no bound up to the file's size."""
    from app.scene.parse import MAX_ZONES

    cfg = {"mesh": {"size": 0.2, kind: [dict(entry) for _ in range(MAX_ZONES + 1)]},
           "body": [{"name": "b", "shape": {"type": "rectangle", "origin": [0.0, 0.0],
                                            "width": 1.0, "height": 1.0}}]}
    with pytest.raises(InputError, match=rf"mesh.{kind} has 1001 entries, more than 1000"):
        parse_scene(cfg)
    cfg["mesh"][kind] = cfg["mesh"][kind][:MAX_ZONES]
    parse_scene(cfg)


def test_too_many_named_points_is_one_line() -> None:
    """Before: 100,000 [points] names ran patch.toml for 106 s (a search of every node per
    name) and wrote a 14.9 MB summary.json."""
    from app.scene.parse import MAX_NAMED_POINTS

    body = {"name": "b", "shape": {"type": "rectangle", "origin": [0.0, 0.0], "width": 1.0,
                                   "height": 1.0}}
    points = {f"p{k}": [0.0, 0.0] for k in range(MAX_NAMED_POINTS + 1)}
    with pytest.raises(InputError, match=r"\[points\] has 1001 names, more than 1000"):
        parse_scene({"mesh": {"size": 0.2}, "body": [body], "points": points})
    points.pop("p0")
    assert len(parse_scene({"mesh": {"size": 0.2}, "body": [body], "points": points}).points) \
        == MAX_NAMED_POINTS


def test_a_wrong_side_of_a_many_cornered_polygon_is_a_short_line(tmp_path):
    """The error listed every side: one line of 119 kB for 10,000 corners, 22 kB for 2000
    (the test's 2000: 10,000 take 24 s of CPU in the crossing test)."""
    n = 2000
    angles = 2 * math.pi * np.arange(n) / n
    poly = ", ".join(f"[{math.cos(a):.9f}, {1.5 + 0.4 * math.sin(a):.9f}]" for a in angles)
    text = (CONFIGS / "patch.toml").read_text().replace(
        'type = "rectangle"\norigin = [0.0, 1.0]\nwidth = 2.0\nheight = 1.0\nstructured = true',
        f'type = "polygon"\npoints = [{poly}]', 1)
    path = tmp_path / "many.toml"
    path.write_text(text)
    with pytest.raises(InputError, match=r"curves.bottom is not a side of a polygon") as exc:
        load_config(path)
    assert len(str(exc.value)) < 400 and "side1999" in str(exc.value), str(exc.value)[:400]


def _all_pairs_first_crossing(p: np.ndarray) -> tuple[int, int] | None:
    """The quadratic test the sweep replaced: every pair i < j, the first in i, then j."""
    n = len(p)
    q = np.roll(p, -1, axis=0)
    d = q - p
    span = float(np.sqrt(np.max(np.einsum("ij,ij->i", d, d))))
    i, j = np.triu_indices(n, 1)
    return polygon_simple._crossing_pairs(p, q, d, span, i, j)


def _random_outlines() -> list[np.ndarray]:
    rng = np.random.default_rng(7)
    cases = [rng.random((int(rng.integers(3, 40)), 2)) for _ in range(200)]
    for n in (12, 60, 300):  # near-simple: a circle with noise, a corner swapped
        c = _circle(n) * (1 + 0.3 * rng.random((n, 1)))
        cases += [c, c[np.r_[0:5, 6, 5, 7:n]], np.round(c, 1)]
    grid = rng.integers(0, 4, (300, 6, 2)).astype(float)  # collinear and touching sides
    cases += list(grid)
    cases.append(np.array([[0, 0], [2, 0], [1, 0], [1, 1.0]]))  # folds back
    return cases


def test_the_sweep_finds_the_same_first_pair_as_all_pairs(monkeypatch) -> None:
    cases = _random_outlines()
    want = [_all_pairs_first_crossing(p) for p in cases]
    assert sum(w is None for w in want) > 20 and sum(w is not None for w in want) > 200
    assert [polygon_simple.crossing_sides(p) for p in cases] == want
    monkeypatch.setattr(polygon_simple, "PAIRS_PER_BLOCK", 5)
    assert [polygon_simple.crossing_sides(p) for p in cases] == want


def test_a_round_outline_tests_few_pairs(monkeypatch) -> None:
    """Before, every one of the n^2 / 2 pairs was tested: 23.6 s of CPU at 10,000 corners
    (`load_config`); the sweep tests those whose x (or y) intervals overlap."""
    tested = []
    inner = polygon_simple._crossing_pairs

    def counted(p, q, d, span, i, j):
        tested.append(len(i))
        return inner(p, q, d, span, i, j)

    monkeypatch.setattr(polygon_simple, "_crossing_pairs", counted)
    assert polygon_simple.crossing_sides(_circle(MAX_POINTS)) is None
    assert sum(tested) < 20 * MAX_POINTS, sum(tested)  # 5e7 before
