"""app/contact/resolution.py: stripes need both a coarse master and a striped profile."""

from __future__ import annotations

import numpy as np
import pytest

from app.contact.pairs import ContactPairs
from app.contact.resolution import (
    master_slave_size_ratio,
    stripe_checks,
    stripe_warning,
)
from app.mesh.model import Mesh


def flat_interface(master_h: float, traction) -> tuple[Mesh, ContactPairs, np.ndarray]:
    """Slave nodes every 0.05 on y = 0 over [-1, 1], each paired with the master segment
    (nodes every master_h on y = 0) below it; the normal forces traction(x) x length."""
    xs = np.linspace(-1.0, 1.0, 41)
    xm = np.arange(-1.0, 1.0 + 1e-9, master_h)
    n_s = xs.size
    points = np.vstack([np.c_[xs, np.zeros(n_s)], np.c_[xm, np.zeros(xm.size)]])
    seg = np.minimum(np.floor((xs + 1.0) / master_h + 1e-9), xm.size - 2).astype(int)
    master = np.c_[seg, seg + 1] + n_s
    length = np.full(n_s, 0.05)
    length[[0, -1]] = 0.025
    m = n_s
    pairs = ContactPairs(np.zeros(m, int), np.arange(m), master, np.zeros(m),
                         np.tile([0.0, 1.0], (m, 1)), np.tile([-1.0, 0.0], (m, 1)),
                         np.zeros(m), points[:n_s], length)
    mesh = Mesh(points, np.zeros((0, 4), int), np.zeros(0, int), [])
    return mesh, pairs, traction(xs) * length


def smooth(x):
    return 1.0 - 0.5 * x * x


def striped(x):  # bumps of 20% with the period of 0.2 master segments
    return smooth(x) * (1.0 + 0.2 * np.abs(np.sin(np.pi * (x + 1.0) / 0.2)))


def test_size_ratio_is_master_over_slave():
    mesh, pairs, _ = flat_interface(0.2, smooth)
    assert master_slave_size_ratio(mesh, pairs, np.ones(41, bool)) == pytest.approx(4.0)
    assert np.isnan(master_slave_size_ratio(mesh, pairs, np.zeros(41, bool)))


@pytest.mark.parametrize("master_h, traction, warn", [
    (0.2, striped, True),    # coarse master, striped: reported
    (0.2, smooth, False),    # coarse master that the profile does not see
    (0.05, striped, False),  # a striped profile on a matching master: not this cause
])
def test_stripe_checks_need_cause_and_symptom(master_h, traction, warn):
    mesh, pairs, force = flat_interface(master_h, traction)
    (check,) = stripe_checks(mesh, pairs, force, ["itf"], force_scale=1.0)
    assert check["warn"] is warn and check["closed"] == 41
    assert (check["deviation"] > 0.05) is (traction is striped)


def test_round_off_forces_and_small_zones_are_not_judged():
    mesh, pairs, force = flat_interface(0.2, striped)
    assert stripe_checks(mesh, pairs, force * 1e-12, ["itf"], force_scale=1.0) == []
    few = np.where(np.abs(pairs.position[:, 0]) < 0.2, force, 0.0)  # 7 closed pairs
    assert stripe_checks(mesh, pairs, few, ["itf"], force_scale=1.0) == []
    # nothing loads the problem (held bodies, no load): the forces are all round-off
    assert stripe_checks(mesh, pairs, force * 1e-13, ["itf"], force_scale=0.0) == []


def test_stripe_warning_names_interface_step_and_ratio():
    mesh, pairs, force = flat_interface(0.2, striped)
    (check,) = stripe_checks(mesh, pairs, force, ["indent"], force_scale=1.0)
    text = stripe_warning(check, 3)
    assert text.startswith("interface 'indent', step 3:") and "4.0x" in text
    assert "\n" not in text and 'discretisation = "mortar-smooth"' in text


def test_stripe_warning_under_mortar_smooth_offers_the_other_remedies():
    mesh, pairs, force = flat_interface(0.2, striped)
    (check,) = stripe_checks(mesh, pairs, force, ["indent"], force_scale=1.0)
    text = stripe_warning(check, 3, "mortar-smooth")
    assert "mortar-smooth" not in text.split(":", 2)[2].split("(README")[0]
    assert "coarser side the slave" in text and "refine the master" in text


def two_zones(x):  # two separate smooth contact zones, |x| in [0.35, 1], a sharp inner edge
    a = np.abs(x)
    p = np.where(a > 0.34, 1.0 - 0.3 * ((a - 0.675) / 0.325) ** 2, 0.0)
    return np.where(np.abs(a - 0.35) < 1e-9, 0.3 * p, p)


def test_two_separate_zones_are_judged_apart():
    """A disk resting in a V-notch: two smooth zones on one interface, a coarse master.
    Judged as one sequence, the inner contact edges read as a 21% deviation (a false
    stripe warning); zone by zone there is none."""
    mesh, pairs, force = flat_interface(0.2, two_zones)
    (check,) = stripe_checks(mesh, pairs, force, ["v"], force_scale=1.0)
    assert check["warn"] is False and check["deviation"] < 0.05
    # stripes inside each zone are still found
    _, _, striped_force = flat_interface(0.2, lambda x: two_zones(x) * striped(x) / smooth(x))
    (check,) = stripe_checks(mesh, pairs, striped_force, ["v"], force_scale=1.0)
    assert check["warn"] is True


def test_a_node_lifted_off_by_stripes_does_not_split_the_zone():
    """Stripes strong enough to open a slave node inside the zone (multibody `indent` at
    step 1): a hole shorter than a master element is still one zone, and it warns."""
    mesh, pairs, force = flat_interface(0.2, striped)
    force[20] = 0.0  # the node at x = 0 opens
    (check,) = stripe_checks(mesh, pairs, force, ["itf"], force_scale=1.0)
    assert check["warn"] is True and check["closed"] == 40
