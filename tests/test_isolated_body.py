"""A body with no support and no interface, in a scene whose other bodies are in contact:
the one-line error names the body and its free modes ('nothing holds it'), as it does in a
scene without interfaces; before, it said "bodies 'loose' are free to move together"."""

from __future__ import annotations

from tests.support import CONFIGS, read_summary, rectangle_body, run_cli

LOOSE = "\n" + rectangle_body("loose", (4.0, 0.0), extra="size = 0.5\n")


def test_isolated_body_among_contacting_ones_is_named(tmp_path):
    text = (CONFIGS / "two_blocks.toml").read_text()
    i = text.index("[[support]]")
    cfg = tmp_path / "loose.toml"
    cfg.write_text(text[:i] + LOOSE + text[i:])
    res = run_cli(["run", str(cfg), "--out", str(tmp_path / "out")])
    assert res.returncode == 2, res.stderr
    errors = [ln for ln in res.stderr.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "Traceback" not in res.stderr, res.stderr
    assert "body 'loose' is free to move (" in errors[0], errors[0]
    assert "nothing holds it" in errors[0] and "together" not in errors[0]
    assert read_summary(tmp_path / "out")["status"] == "failed"
