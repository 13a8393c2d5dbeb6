"""Parameter studies (`study --sweep`, app/studies/sweep.py) on coarse meshes: CSV, plots and the
contact's physics (balance, friction + bond bound, sliding at mu P)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from support import CONFIGS, read_csv, read_summary, run_cli

from app.errors import InputError
from app.studies.sweep import parse_sweeps, report_step, split_values


def test_split_and_parse_sweeps():
    assert split_values("0.1, 0.2,[1, 2],'a,b'") == ["0.1", "0.2", "[1, 2]", "'a,b'"]
    assert parse_sweeps(["interface.bond.c=1,2", "load.0.total_force=[0, 1],[0, 2]"]) == [
        ("interface.bond.c", ["1", "2"]), ("load.0.total_force", ["[0, 1]", "[0, 2]"])]
    for bad in ("mu", "=1,2", "interface.contact.mu="):
        with pytest.raises(InputError, match="--sweep"):
            parse_sweeps([bad])
    # a key swept twice ran only its last values, reported under one column
    with pytest.raises(InputError, match="swept twice"):
        parse_sweeps(["interface.bond.c=4", "interface.bond.a=1", "interface.bond.c=6"])


def test_report_step_is_a_step_of_the_run():
    assert [report_step(k, 20) for k in (0, 1, 20, -1, -19)] == [20, 1, 20, 19, 1]
    for bad in (21, -20):  # were clamped to the last / first step, the plot saying "step 21"
        with pytest.raises(InputError, match="--at-step"):
            report_step(bad, 20)


def test_sweep_at_step_beyond_the_steps_fails(tmp_path):
    res = run_cli(["study", str(CONFIGS / "bonded.toml"), "--sweep", "interface.bond.c=4",
                   "--at-step", "50", "--out", str(tmp_path), "--quiet"])
    assert res.returncode == 2
    assert res.stderr.strip().splitlines()[-1].startswith("error: every run of the sweep")
    assert "--at-step 50: the run has 20 steps" in res.stderr


def test_sweep_mu_on_cattaneo_balances_the_load_below_mu_p(tmp_path):
    out = tmp_path / "mu"
    res = run_cli(["study", str(CONFIGS / "cattaneo.toml"), "--mesh-size", "1.0",
                   "--sweep", "interface.contact.mu=0.1,0.2,0.4", "--out", str(out)])
    assert res.returncode == 0, res.stderr
    assert "run 3/3 interface.contact.mu=0.4" in res.stderr  # progress per run
    rows = read_csv(out / "sweep.csv")
    assert [float(r["interface.contact.mu"]) for r in rows] == [0.1, 0.2, 0.4]
    assert (out / "sweep_interface_contact_mu.png").stat().st_size > 5000
    stick = []
    for r in rows:
        mu, p, q = (float(r[k]) for k in ("interface.contact.mu", "normal_force",
                                          "tangential_force"))
        assert q == pytest.approx(86.3, rel=1e-9)  # the applied tangential load
        assert q <= mu * p
        stick.append(float(r["stick_length"]))
    assert stick[0] < stick[1] < stick[2]  # more friction, larger stick zone
    for s in read_csv(out / "sweep_steps.csv"):
        mu = float(s["interface.contact.mu"])
        assert abs(float(s["tangential_force"])) <= mu * float(s["normal_force"]) * (1 + 1e-9)


def test_sweep_c_and_a_on_bonded_bounds_and_sliding(tmp_path):
    out = tmp_path / "bond"
    res = run_cli(["study", str(CONFIGS / "bonded.toml"), "--sweep", "interface.bond.c=1,8",
                   "--sweep", "interface.bond.a=1,3", "--at-step", "10", "--out", str(out),
                   "--quiet"])
    assert res.returncode == 0, res.stderr
    rows = read_csv(out / "sweep.csv")
    assert len(rows) == 4 and all(r["status"] == "completed" for r in rows)
    for key in ("c", "a"):
        assert (out / f"sweep_interface_bond_{key}.png").is_file()
    peaks = {(r["interface.bond.c"], r["interface.bond.a"]): float(r["peak_tangential_force"])
             for r in rows}
    # the values as given (ints: before, float() wrote them 8.0 and 3.0)
    assert peaks[("8", "3")] > peaks[("1", "3")]  # a stronger bond resists more
    sliding = 0
    for s in read_csv(out / "sweep_steps.csv"):
        mu = 0.3
        p, q, strength = (float(s[k]) for k in ("normal_force", "tangential_force",
                                                "bond_strength_force"))
        # c L: intact strength c x bonded length (thickness 1), 0 once debonded
        assert abs(q) <= mu * max(p, 0.0) + strength + 1e-9 * max(1.0, strength)
        slip, contact = float(s["slip_length"]), float(s["contact_length"])
        if int(s["debonded_pairs"]) == int(s["n_pairs"]) and slip > 0 and slip == contact \
                and float(s["open_length"]) == 0:
            assert abs(q) == pytest.approx(mu * p, rel=1e-6)  # fully debonded, sliding
            sliding += 1
    assert sliding >= 4
    for r in rows:
        assert int(r["debond_start_step"]) <= int(r["debond_complete_step"])


def test_sweep_and_study_exit_nonzero_when_every_run_fails(tmp_path):
    # frictionless contact cannot carry cattaneo's tangential load: every run fails
    args = [str(CONFIGS / "cattaneo.toml"), "--mesh-size", "1.0", "--out", str(tmp_path)]
    res = run_cli(["study", *args, "--sweep", "interface.contact.mu=0,1e-9"])
    assert res.returncode == 2
    line = res.stderr.strip().splitlines()[-1]
    assert line.startswith("error: every run of the sweep")
    s = read_summary(tmp_path)  # the sweep's own summary.json says so (before: none)
    assert (s["status"], s["study"], "error: " + s["error"]) == ("failed", "sweep", line)
    res = run_cli(["study", *args, "--set", "interface.contact.mu=0", "--levels", "1",
                   "--methods", "4", "--quiet"])
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: every run of the study failed")
    s = read_summary(tmp_path)
    assert (s["status"], s["study"], "error: " + s["error"]) == ("failed", "convergence",
                                                                  lines[0])
    assert read_summary(tmp_path / "L0_4SD")["status"] == "failed"


def test_sweep_combination_rejected_by_the_config_checks_fails_alone(tmp_path):
    res = run_cli(["study", str(CONFIGS / "bonded.toml"), "--sweep", "interface.bond.c=0.5,4",
                   "--out", str(tmp_path), "--quiet"])
    assert res.returncode == 0, res.stderr
    rows = read_csv(tmp_path / "sweep.csv")
    assert [r["status"] for r in rows] == ["failed", "completed"]
    assert "c = 0.5 < mu * a" in rows[0]["error"]


def test_sweep_dissipation_is_each_interfaces_own(tmp_path):
    """squeezed.toml: the bottom face slips, the top one sticks. Each interface row carried
    the step's total dissipation (the bottom's work was reported on the top too)."""
    import json

    res = run_cli(["study", str(CONFIGS / "hard" / "squeezed.toml"), "--sweep",
                   "load.0.total_force=[2.0,0.0]", "--out", str(tmp_path), "--quiet"])
    assert res.returncode == 0, res.stderr
    steps = read_csv(tmp_path / "sweep_steps.csv")
    total = [st["dissipation"] for st in
             json.loads((tmp_path / "run_000" / "summary.json").read_text())["steps"]]
    for k, d in enumerate(total, start=1):
        mine = {r["interface"]: float(r["dissipation"]) for r in steps if int(r["step"]) == k}
        assert mine["top"] == 0.0 and mine["bottom"] > 0
        assert abs(mine["top"] + mine["bottom"] - d) <= 1e-12 * d
    rows = {r["interface"]: float(r["dissipation"]) for r in read_csv(tmp_path / "sweep.csv")}
    assert rows["top"] == 0.0 and abs(rows["bottom"] - sum(total)) <= 1e-12 * sum(total)


def test_contact_length_counts_no_round_off_forces_and_not_the_ranks(tmp_path):
    """bonded.toml step 15: the block is off at zero load (normal force 7e-14) and the pair
    forces are round-off (1e-15); contact_length counted those with p > 0: 1.31 of 2.0
    on 1 rank and 1.53 on 2."""
    lengths = []
    for ranks in (1, 2):
        out = tmp_path / f"np{ranks}"
        res = run_cli(["study", str(CONFIGS / "bonded.toml"), "--sweep", "interface.bond.c=6",
                       "--out", str(out), "--quiet"], ranks=ranks)
        assert res.returncode == 0, res.stderr
        steps = read_csv(out / "sweep_steps.csv")
        peak = max(abs(float(r["normal_force"])) for r in steps)
        for r in steps:
            if abs(float(r["normal_force"])) < 1e-10 * peak:
                assert float(r["contact_length"]) == 0.0, r
        assert any(float(r["contact_length"]) == 2.0 for r in steps)  # pressed: all of it
        lengths.append([float(r["contact_length"]) for r in steps])
    assert lengths[0] == lengths[1]


def test_a_sweep_over_text_values_is_plotted_on_a_categorical_axis(tmp_path):
    """`--sweep 'interface.bond.discretisation="mortar","node-to-segment"'` wrote no plot
    for the key, silently."""
    from app.studies.sweep import plot_sweep

    key = "interface.bond.discretisation"
    rows = [{key: v, "interface.bond.c": c, "status": "completed", "interface": "bond",
             "normal_force": 2.0, "tangential_force": c, "dissipation": 0.02}
            for v in ('"mortar"', '"node-to-segment"') for c in (2.0, 6.0)]
    paths = plot_sweep(rows, [key, "interface.bond.c"], tmp_path)
    assert [p.name for p in paths] == ["sweep_interface_bond_discretisation.png",
                                       "sweep_interface_bond_c.png"]
    rows[0][key] = 1.0  # numbers and text mixed: no axis for that key
    assert [p.name for p in plot_sweep(rows, [key], tmp_path)] == []


def test_a_negative_at_step_is_named_by_the_step_it_reports():
    """The plots' titles read "at step -3", and sweep.csv did not say which step."""
    from app.studies.sweep import report_label, summarize

    steps = [{"step": k, "normal_force": 1.0, "tangential_force": 0.1 * k,
              "max_pressure": 2.0, "debonded_pairs": 0, "n_pairs": 4, "dissipation": 0.0,
              **{f"{z}_length": 0.0 for z in ("contact", "stick", "slip", "open", "bonded")}}
             for k in range(1, 21)]
    row = summarize(steps, -3)
    assert row["step"] == 17 and row["tangential_force"] == pytest.approx(1.7)
    assert summarize(steps, 0)["step"] == 20 and summarize(steps, 5)["step"] == 5
    assert report_label([row, dict(row)], -3) == "step 17"
    assert report_label([row, row | {"step": 9}], -3) == "3 steps before the last"
    assert report_label([row], 0) == "the last step" and report_label([row], 4) == "step 4"


def test_the_sweep_line_of_a_job_ended_by_another_ranks_failure_says_failed(tmp_path,
                                                                           monkeypatch):
    """The stop hook's `sweep:` line says what the summaries say: `failed` when mpiexec's
    SIGTERM answered a rank that failed alone (app/output/status.py `stop_status`),
    `interrupted` for a signal. Before, `interrupted` after the failing rank's line."""
    from app.output import status
    from app.studies import sweep as sweep_mod

    monkeypatch.setattr(sweep_mod, "plot_sweep", lambda *a, **k: [])
    sweep = sweep_mod.Sweep(Path("c.toml"), [], ["k"], [("1",), ("2",)], tmp_path, {}, 0,
                            True, rows=[{"k": 1.0, "status": "completed"}])
    for state in ("failed", "interrupted"):
        monkeypatch.setattr(status, "_STOP_STATUS", [state])
        assert sweep_mod._write_completed(sweep).startswith(f"sweep: {state}; its 1 rows")
    assert [r["status"] for r in read_csv(tmp_path / "sweep.csv")] == ["completed", "not run"]


def test_every_quantity_of_a_sweep_panel_is_drawn_visibly():
    """The zone-lengths panel's fifth quantity (bonded length) was drawn with a line 0.2 pt
    wide and markers 1 pt across (widths and sizes fell by a fixed step per quantity), so
    the bonded length of `bonded.toml --sweep interface.bond.c=...` hardly showed."""
    from app.plotting import pyplot
    from app.studies.sweep import PANELS, _sweep_panel

    plt = pyplot()
    title, cols = max(PANELS, key=lambda p: len(p[1]))
    assert len(cols) >= 5
    rows = [{"k": k, **{c: float(i + k) for i, c in enumerate(cols)}} for k in (1.0, 2.0)]
    fig, ax = plt.subplots()
    try:
        _sweep_panel(ax, title, list(cols), [rows], "k", "the last step")
        widths = [line.get_linewidth() for line in ax.lines]
        sizes = [line.get_markersize() for line in ax.lines]
    finally:
        plt.close(fig)
    assert len(widths) == len(cols)
    assert min(widths) >= 0.8 and min(sizes) >= 3.0
    assert widths == sorted(widths, reverse=True)  # thick first: coinciding curves all show
    assert sizes == sorted(sizes, reverse=True)


def test_swept_text_values_are_written_without_their_toml_quotes():
    """`--sweep 'analysis.method="cs-fem","fem-q4"'` wrote `\"\"\"cs-fem\"\"\"` into
    sweep.csv (the value '"cs-fem"' with its quotes), and the legends showed them."""
    from app.studies.sweep import _value

    assert _value('"cs-fem"') == "cs-fem" and _value("'node-to-segment'") == "node-to-segment"
    assert _value("0.3") == 0.3 and _value("1") == 1  # numbers stay numbers (plot axes)
    assert _value("mortar") == "mortar"  # a bare word, as --set reads it
    assert _value("[1, 2]") == "[1, 2]"  # not a scalar: its text


def test_a_swept_integer_keeps_its_type_in_sweep_csv_and_the_legends(tmp_path):
    """`--sweep analysis.sd=1,2` wrote `1.0` and `2.0` into sweep.csv (float() of the
    text): the key is an integer, as the run reads it."""
    from app.plotting import pyplot
    from app.studies.convergence import csv_text
    from app.studies.sweep import _style_legend, _value, plot_sweep

    assert type(_value("1")) is int and type(_value("1.0")) is float
    assert type(_value("1e3")) is float and _value("true") == "true"
    text = csv_text([{"analysis.sd": _value(v), "status": "completed"} for v in ("1", "2")])
    assert text.splitlines()[1:] == ["1,completed", "2,completed"]
    fig, ax = pyplot().subplots()
    _style_legend(ax, [("bond", _value("2"), _value("0.25"))], ["analysis.sd", "mu"])
    assert ax.get_legend().get_texts()[0].get_text() == "interface bond, analysis.sd=2, mu=0.25"
    # ints and floats on one axis (mu=0,0.5) are numbers alike: the plot is drawn
    rows = [{"mu": _value(v), "status": "completed", "interface": "bond",
             "normal_force": 1.0, "tangential_force": 0.1} for v in ("0", "0.5")]
    assert [p.name for p in plot_sweep(rows, ["mu"], tmp_path)] == ["sweep_mu.png"]


def test_a_value_swept_twice_is_an_error_naming_it():
    """`--sweep mu=0.1,0.1` ran the same combination twice (two identical rows)."""
    for item, same in (("interface.contact.mu=0.1,0.2,0.1", "the value 0.1 is given twice"),
                       ("analysis.sd=1,1.0", "1 and 1.0 are the same value"),
                       ("m=0.1,1e-1", "0.1 and 1e-1 are the same value"),
                       ('analysis.method="cs-fem",\'cs-fem\'',
                        "\"cs-fem\" and 'cs-fem' are the same value")):
        with pytest.raises(InputError, match=re.escape(same)):
            parse_sweeps([item])
    assert parse_sweeps(['k="1",1']) == [("k", ['"1"', "1"])]  # text and number differ


def test_a_sweep_over_a_supports_group_checks_each_runs_name(tmp_path):
    """The config's support names are checked before meshing (app/assembly/loads.py
    check_groups_before_meshing): for a sweep, each run's, not the base config's, which
    the swept key replaces in every run (a template's placeholder; before, the whole sweep
    was refused: `error: support on 'PLACEHOLDER': unknown group`). A swept name that is
    no group fails its run alone, before its mesh."""
    res = run_cli(["study", str(CONFIGS / "patch.toml"), "--set",
                   'support.0.on="PLACEHOLDER"', "--sweep",
                   'support.0.on="lower_base","nope"', "--mesh-size", "1.0", "--out",
                   str(tmp_path), "--quiet"])
    assert res.returncode == 0, res.stderr
    rows = read_csv(tmp_path / "sweep.csv")
    assert [(r["support.0.on"], r["status"]) for r in rows] == [("lower_base", "completed"),
                                                                ("nope", "failed")]
    assert rows[1]["error"].startswith("support on 'nope': unknown group 'nope' (curves: [")
    # rejected before its run, as a value the config checks reject: no run_001 (before
    # this check, the run meshed and failed there, leaving run_001/summary.json)
    assert not (tmp_path / "run_001").exists() and (tmp_path / "run_000").is_dir()


def test_a_sweep_of_a_scene_without_interfaces_has_a_row_per_run(tmp_path):
    """sweep.csv has one row per combination and interface: a scene without [[interface]]
    (cantilever.toml) had none, so its completed runs left an empty sweep.csv and a
    summary.json of `rows` 0, and an interrupted sweep would have counted them as not
    run. Now each completed run has its row (no interface: its DOFs and seconds)."""
    res = run_cli(["study", str(CONFIGS / "cantilever.toml"), "--sweep",
                   "body.beam.E=1000.0,2000.0", "--mesh-size", "1.0", "--out", str(tmp_path),
                   "--quiet"])
    assert res.returncode == 0, res.stderr
    rows = read_csv(tmp_path / "sweep.csv")
    assert [(r["body.beam.E"], r["status"], r["interface"]) for r in rows] == [
        ("1000.0", "completed", ""), ("2000.0", "completed", "")]
    n_dofs = read_summary(tmp_path / "run_000")["n_dofs"]
    assert [int(r["n_dofs"]) for r in rows] == [n_dofs, n_dofs] and n_dofs > 0
    assert read_summary(tmp_path)["rows"] == 2
    assert not list(tmp_path.glob("*.png"))  # no contact figures: no empty panels drawn
