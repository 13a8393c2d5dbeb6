"""`study --reference richardson` (the default): the Richardson-extrapolated reference
columns on a contact scene (with --reference-levels) and on the cantilever (named point),
levels 0-2."""

from __future__ import annotations

import math

import pytest
from support import CONFIGS, read_csv, run_cli


def test_richardson_reference_on_hertz_halfspace(tmp_path):
    out = tmp_path / "hz"
    res = run_cli(["study", str(CONFIGS / "hertz_halfspace.toml"), "--levels", "2",
                   "--reference-levels", "1", "--methods", "4,q4", "--out", str(out),
                   "--quiet"])
    assert res.returncode == 0, res.stderr
    rows = read_csv(out / "study.csv")
    lims = {(r["method"], r["quantity"]): r for r in read_csv(out / "richardson.csv")}
    assert set(lims) == {(m, q) for m in ("4SD", "FEM-Q4") for q in ("energy", "p_max")}
    u_ref = float(lims[("4SD", "energy")]["value"])
    assert lims[("4SD", "energy")]["levels"] == "0-2"  # the reference runs one level more
    assert lims[("FEM-Q4", "energy")]["levels"] == "0-1"
    assert lims[("FEM-Q4", "energy")]["order_source"] == "theoretical"  # two levels only
    assert {(r["method"], r["level"]) for r in rows} == {
        ("4SD", "0"), ("4SD", "1"), ("4SD", "2"), ("FEM-Q4", "0"), ("FEM-Q4", "1")}
    assert float(lims[("4SD", "energy")]["rel_to_reference"]) == 0.0
    for (_, _), r in lims.items():
        assert float(r["uncertainty_rel"]) >= 0 and r["order_source"] in ("observed",
                                                                          "theoretical")
    # the methods' own limits agree with the reference method's within the uncertainty
    q4 = lims[("FEM-Q4", "energy")]
    assert float(q4["rel_to_reference"]) <= 2 * (float(q4["uncertainty_rel"])
                                                + float(lims[("4SD", "energy")]
                                                        ["uncertainty_rel"]))
    for r in rows:
        u = float(r["strain_energy"])
        # every run, the reference's finest level included, has a scalar error against U*
        assert float(r["ref_energy"]) == pytest.approx(abs(u - u_ref) / abs(u_ref), rel=1e-9)
        is_ref = r["method"] == "4SD" and r["level"] == "2"
        for col in ("ref_pressure_l2", "ref_pressure_l2_core"):
            assert math.isnan(float(r[col])) == is_ref  # fields: the finest level of 4SD
        assert math.isfinite(float(r["ref_p_max"]))
    for m in ("4SD", "FEM-Q4"):
        e = [float(r["ref_energy"]) for r in sorted((r for r in rows if r["method"] == m),
                                                    key=lambda r: int(r["level"]))]
        assert all(a > b > 0 for a, b in zip(e, e[1:], strict=False))
        rr = [r for r in rows if r["method"] == m and r["level"] == "1"]
        assert float(rr[0]["order_ref_energy"]) > 1.5  # about 2 in h
        core, full = (float(next(r for r in rows if r["method"] == m and r["level"] == "0")
                            [c]) for c in ("ref_pressure_l2_core", "ref_pressure_l2"))
        assert 0 < core < full
    text = (out / "study_tables.md").read_text()
    assert "Richardson limits of 4SD" in text and "observed orders against the reference" in text


def test_richardson_reference_named_point_and_finest_mode(tmp_path):
    out = tmp_path / "beam"
    args = ["study", str(CONFIGS / "cantilever.toml"), "--levels", "3", "--mesh-size", "0.25",
            "--methods", "4", "--out", str(out), "--quiet"]
    res = run_cli(args)
    assert res.returncode == 0, res.stderr
    lims = {r["quantity"]: r for r in read_csv(out / "richardson.csv")}
    assert set(lims) == {"energy", "tip"}
    tip = float(lims["tip"]["value"])
    rows = sorted(read_csv(out / "study.csv"), key=lambda r: int(r["level"]))
    errs = [float(r["ref_tip"]) for r in rows]
    assert errs[0] > errs[1] > errs[2] > 0
    finest, finest_err = float(lims["tip"]["finest"]), float(rows[-1]["err_tip_deflection"])
    assert abs(tip - finest) / abs(tip) == pytest.approx(errs[2])
    # the finest level is too stiff (|u| low), so Timoshenko's tip is finest / (1 - err);
    # the extrapolated tip is at least ten times closer to it than the finest level's
    exact = finest / (1 - finest_err)
    assert abs(finest) < abs(tip) and abs(tip - exact) / abs(exact) < finest_err / 10
    res = run_cli([*args[:-3], "--reference", "finest", "--out", str(tmp_path / "f"),
                   "--quiet"])
    assert res.returncode == 0, res.stderr
    assert not (tmp_path / "f" / "richardson.csv").exists()
    assert math.isnan(float(read_csv(tmp_path / "f" / "study.csv")[-1]["ref_tip"]))
    res = run_cli([*args[:-3], "--reference", "median", "--out", str(tmp_path / "g")])
    assert res.returncode == 2 and "--reference" in res.stderr
