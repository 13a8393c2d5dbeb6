"""The per-step crossing checks of app/driver/contact.py: their undeformed half (curves,
orientation, each node's closest segment) is built once per run, not every step."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from test_contact_pairs import stacked

import app.driver.contact as dc


def _run_like(mesh, pairs) -> tuple[SimpleNamespace, SimpleNamespace]:
    """A run's context (one interface, warnings collected) and model, as the driver uses them."""
    itf = SimpleNamespace(name="t", slave="up_bottom", master="low_top", search_distance=0.05)
    warned: list[str] = []
    ctx = SimpleNamespace(cfg=SimpleNamespace(interfaces=[itf]),
                          warn=lambda text, key: warned.append(text), warned=warned)
    contact = SimpleNamespace(pairs=pairs, described={"t": {"pairs_on": "up_bottom"}})
    return ctx, SimpleNamespace(mesh=mesh, contact=contact, watches=[])


def test_the_undeformed_search_runs_once_for_all_steps(monkeypatch):
    mesh = stacked(4, 4, gap=0.2)  # no node within search_distance: no pair
    none = np.zeros(0, dtype=np.int64)
    pairs = SimpleNamespace(slave=none, interface=none)
    ctx, model = _run_like(mesh, pairs)
    built = []
    for name in ("unpaired_watch", "penetration_watch"):
        inner = getattr(dc, name)
        monkeypatch.setattr(dc, name, lambda *a, _f=inner, _n=name: built.append(_n) or _f(*a))
    for step, dy in enumerate((-0.05, -0.1, -0.3)):
        u = np.zeros((mesh.n_nodes, 2))
        u[mesh.node_body() == 1, 1] = dy
        dc._crossing_warnings(ctx, model, u.ravel(), step)
    assert built == ["unpaired_watch", "penetration_watch"]  # once, at the first step
    # the third step pushed the block 0.1 through its master, and the master through it
    crossed, behind = ctx.warned
    assert crossed.startswith("interface 't', step 3: 5 slave node(s) without a contact pair")
    assert behind.startswith("interface 't', step 3: 5 node(s) of the master 'low_top'")
