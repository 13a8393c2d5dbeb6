"""The words of the contact LCP's lines (app/interface/coulomb.py)."""

from types import SimpleNamespace

import numpy as np


def test_a_failed_search_line_keeps_lemke_apart_from_the_search_notes(monkeypatch):
    """Before: `..., then no nodes left (Lemke: warm start failed)`, the Lemke part read as
    the node count's. Now Lemke's run from the search's last candidate basis is a clause of
    its own, after the search's notes."""
    import app.interface.coulomb as coulomb

    def search(ms, qs, accept, widen):
        accept(np.array([True]))
        return None, "a mixed-integer search found no solution below 1e+01, then no nodes left"

    monkeypatch.setattr(coulomb, "complementary_basis", search)
    fake = SimpleNamespace(
        cache=None, _slip_widen=lambda: np.ones(1),
        solver=lambda *a, **k: SimpleNamespace(status="warm start failed"))
    res = SimpleNamespace(message="secondary ray after 4 pivots", pivots=4)
    out = coulomb.ContactLCP._searched(fake, res, np.eye(1), -np.ones(1))
    assert out.message == ("secondary ray after 4 pivots; a mixed-integer search found no "
                           "solution below 1e+01, then no nodes left; Lemke from the "
                           "search's last candidate basis ended 'warm start failed'")
