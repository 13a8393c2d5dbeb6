"""Supports of many bodies (app/assembly/loads.py, all_support_dofs).

Before, `support_dofs` computed the scene's size (a pass over every node) for each
support: supports x nodes per pass, and the set-up makes three passes
(constrained_dofs, load_cases, the reaction probe); 5000 one-element bodies with a
support each spent 22 s in constrained_dofs alone. Now the size is computed once per pass.
"""

from types import SimpleNamespace

import numpy as np

from app.assembly import loads
from app.assembly.loads import all_support_dofs, constrained_dofs, support_dofs
from app.assembly.loads import scene_size as size_of
from app.mesh.model import Mesh

SQUARE = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)


def _bodies(n: int) -> tuple[Mesh, SimpleNamespace]:
    """n unit squares in a row, each held on its base by a support of its own."""
    x0 = 2.0 * np.arange(n)
    points = (SQUARE[None] + np.c_[x0, np.zeros(n)][:, None, :]).reshape(-1, 2)
    quads = np.arange(4 * n, dtype=np.int64).reshape(n, 4)
    curves = {f"base{k}": np.array([[4 * k, 4 * k + 1]]) for k in range(n)}
    mesh = Mesh(points, quads, np.arange(n), [f"b{k}" for k in range(n)], curves)
    supports = [SimpleNamespace(on=f"base{k}", values={0: 0.0, 1: "0.001 * x"},
                                history=np.ones(1)) for k in range(n)]
    return mesh, SimpleNamespace(supports=supports, parameters={})


def test_many_supports_take_the_scene_size_once(monkeypatch) -> None:
    """One pass over the nodes for the scene's size per set-up pass, not one per support
    (counted, not timed: 4000 bodies took 6.8 s of CPU before, 0.8 s after, on a shared
    machine)."""
    mesh, cfg = _bodies(4000)
    calls = []

    def counted(m: Mesh) -> float:
        calls.append(1)
        return size_of(m)

    monkeypatch.setattr(loads, "scene_size", counted)
    dofs = constrained_dofs(mesh, cfg)
    assert len(dofs) == 4 * 4000
    assert len(calls) == 1


def test_all_support_dofs_is_support_dofs_of_each() -> None:
    mesh, cfg = _bodies(5)
    for (d, v), s in zip(all_support_dofs(mesh, cfg.supports), cfg.supports, strict=True):
        d1, v1 = support_dofs(mesh, s)
        assert np.array_equal(d, d1) and np.array_equal(v, v1)
    assert np.allclose(all_support_dofs(mesh, cfg.supports)[2][1], [0, 0, 0.004, 0.005])
