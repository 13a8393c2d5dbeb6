"""Master nodes behind the deformed slave warn (app/contact/master_penetration.py):
configs/hard/flat_punch.toml with the block's top as slave lets the punch corners sink
into the block by 6% of the largest displacement, with every discretisation; before,
nothing said so. With the punch as slave (as shipped) nothing of the block is behind it."""

from __future__ import annotations

import pytest

from tests.support import CONFIGS, read_summary, run_cli

SCENE = CONFIGS / "hard" / "flat_punch.toml"
SWAP = ["--set", 'interface.contact.slave="block_top"',
        "--set", 'interface.contact.master="punch_bottom"']


def _warnings(tmp_path, name: str, *args: str) -> list[str]:
    out = tmp_path / name
    res = run_cli(["run", str(SCENE), "--out", str(out), "--quiet", *args])
    assert res.returncode == 0, res.stderr
    s = read_summary(out)
    assert abs(s["steps"][-1]["interfaces"]["contact"]["force"][1]) == pytest.approx(20.0, rel=1e-9)
    return [w for w in s.get("warnings", []) if "lie behind the deformed slave" in w]


@pytest.mark.parametrize("how", ["mortar", "node-to-segment"])
def test_punch_corners_behind_the_block_as_slave_warn(tmp_path, how):
    (w,) = _warnings(tmp_path, how, *SWAP,
                     "--set", f'interface.contact.discretisation="{how}"')
    assert "master 'punch_bottom'" in w and "slave 'block_top'" in w and "x=-1" in w
    ratio = float(w.split("% of the largest")[0].rsplit(" ", 1)[1])
    assert 3.0 < ratio < 10.0  # 6.2% measured


def test_punch_as_slave_is_silent(tmp_path):
    assert _warnings(tmp_path, "shipped") == []
