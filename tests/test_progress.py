"""Progress lines: one per step and the closing line of a run."""

from __future__ import annotations

from app.output.progress import final_line, reference_errors, step_line


def test_step_line_names_the_step_states_forces_and_balance():
    info = {"step": 3, "strain_energy": 0.51234, "states": {"stick": 4, "slip+": 0, "open": 2},
            "interfaces": {"bond": {"force": [0.25, -20.0], "max_pressure": 15.5}},
            "balance": {"max_relative_residual": 2.5e-15}}
    line = step_line(info, 20, "level 1 of 0..2 4SD: ")
    assert line == ("level 1 of 0..2 4SD: step 3/20; energy 0.5123; stick 4 open 2; "
                    "bond F=(0.25, -20) max p 15.5; balance 2.5e-15")
    assert step_line({"step": 1, "strain_energy": 1.0}, 1) == "step 1/1; energy 1"


def test_final_line_with_status_and_reference_errors():
    summary = {"label": "CS-FEM-4SD", "status": "interrupted", "n_steps": 10,
               "steps": [{}, {}], "n_dofs": 100, "strain_energy": 1.5,
               "reference": {"type": "hertz", "hertz": {"p_max_rel_error": 0.01,
                                                        "p_max": 3.0}},
               "timings": {"total": 2.0}}
    assert reference_errors(summary) == ["hertz.p_max 1.000e-02"]
    assert final_line(summary, "out/x") == (
        "CS-FEM-4SD: interrupted, 2/10 steps, 100 DOFs, strain energy 1.5, rel. errors: "
        "hertz.p_max 1.000e-02, total 2.00 s -> out/x")
    # a run that failed before the mesh: only what is known
    assert final_line({"status": "failed", "n_steps": 1, "steps": []}, "o") == \
        "run: failed, 0/1 steps -> o"
