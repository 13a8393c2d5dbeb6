"""Every run of a study or sweep records the --set strings it ran with in
`provenance.overrides` (README "summary.json"), as `run` does."""

from __future__ import annotations

from support import CONFIGS, read_summary, run_cli

SET = 'interface.contact.discretisation="mortar-smooth"'


def test_study_runs_record_the_overrides(tmp_path):
    out = tmp_path / "s"
    res = run_cli(["study", str(CONFIGS / "hertz.toml"), "--levels", "1", "--methods", "4",
                   "--mesh-size", "1.0", "--out", str(out), "--quiet", "--set", SET])
    assert res.returncode == 0, res.stderr
    s = read_summary(out / "L0_4SD")
    assert s["provenance"]["overrides"] == [SET]
    assert s["contact_interfaces"]["contact"]["discretisation"] == "mortar-smooth"


def test_sweep_runs_record_the_overrides_and_their_value(tmp_path):
    out = tmp_path / "w"
    res = run_cli(["study", str(CONFIGS / "hertz.toml"), "--mesh-size", "1.0", "--out",
                   str(out), "--quiet", "--set", SET, "--sweep", "interface.contact.mu=0.1,0.2"])
    assert res.returncode == 0, res.stderr
    for i, mu in enumerate(("0.1", "0.2")):
        s = read_summary(out / f"run_{i:03d}")
        assert s["provenance"]["overrides"] == [SET, f"interface.contact.mu={mu}"]
