"""The contact-held-mode warning names mortar on a node-to-segment interface
(app/interface/weak_modes.py NTS_ADVICE): on configs/hard/cylinder_on_cylinder.toml with
the smaller half cylinder as master, node-to-segment lets it turn by 24% of the contact
width however fine the mesh (README "Hard cases"), and the old advice was only to refine."""

from __future__ import annotations

from app.interface.weak_modes import slide_warning
from tests.support import CONFIGS, read_summary, run_cli

SCENE = CONFIGS / "hard" / "cylinder_on_cylinder.toml"
SWAP = ["--set", 'interface.contact.slave="lower_arc"',
        "--set", 'interface.contact.master="upper_arc"']
ENTRY = {"body": "upper", "mode": "rotation about (x=0, y=1)", "interface": "contact",
         "slide": 0.05, "contact_width": 0.16, "slide_ratio": 0.3}


def test_advice_depends_on_the_discretisation():
    assert '"mortar"' in slide_warning(ENTRY, 1, "node-to-segment")
    for how in ("mortar", "mortar-smooth", None):
        text = slide_warning(ENTRY, 1, how)
        assert '"mortar"' not in text and "refine" in text and "support" in text


def _run(tmp_path, name: str, discretisation: str) -> dict:
    out = tmp_path / name
    res = run_cli(["run", str(SCENE), "--out", str(out), "--quiet", *SWAP,
                   "--set", f'interface.contact.discretisation="{discretisation}"'])
    assert res.returncode == 0, res.stderr
    return read_summary(out)


def test_node_to_segment_with_the_small_cylinder_as_master_warns_with_mortar(tmp_path):
    s = _run(tmp_path, "nts", "node-to-segment")
    (w,) = [w for w in s.get("warnings", []) if "held only by contact" in w]
    assert "body 'upper'" in w and 'discretisation = "mortar"' in w
    assert s["reference"]["hertz"]["p_max_rel_error"] > 0.1  # the lopsided answer
    m = _run(tmp_path, "mortar", "mortar")
    assert not [w for w in m.get("warnings", []) if "held only by contact" in w]
    assert m["reference"]["hertz"]["p_max_rel_error"] < 0.01
    assert m["reference"]["hertz"]["pressure_l2_rel_error"] < 0.012
