"""app/assembly/solve.py: the accuracy of iterative solves that the contact LCP gets.

- At the default -ksp_rtol (1e-12) an iterative solve of the free displacements (the LCP's
  data) is refined to round-off: GMRES's
  rtol is on its preconditioned residual, its true relative residual stayed near 1e-12,
  and that error in the free displacements made bonded.toml at --mesh-size 0.8 with
  `-ksp_type gmres -pc_type bjacobi` stop at step 16 on 1 rank (a tangential motion of
  +-1e-13 where the exact one is 0: Lemke ended 'inaccurate').
- A looser user tolerance is kept, with a warning once the residual exceeds 1e-9 (before:
  -ksp_rtol 1e-6 changed a contact state of bonded.toml without a word).
- An error or warning names the option that stopped the KSP (before, -ksp_atol 1e-6 was
  reported as `-ksp_rtol 1e-12: lower -ksp_rtol`).
- A right-hand side that is round-off of the run's forces is judged against them, not
  against itself: -ksp_atol 1e-12 solved a recovery of round-off contact forces (|b| =
  5.9e-12, loads 23.1) as x = 0 and bonded.toml and patch.toml stopped with `relative
  residual 1.00e+00 ... lower -ksp_atol`.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from petsc4py import PETSc

from app.assembly.solve import LOOSE_RESIDUAL, REFINED_RESIDUAL, LinearSolver
from app.driver.contact import _iterative_hint
from app.driver.linear import case_scales, step_force_scales
from app.errors import SolveError
from tests.support import CONFIGS, cleared_petsc_options, read_summary, run_cli

KEYS = ("ksp_type", "pc_type", "ksp_rtol", "ksp_atol", "pc_factor_mat_solver_type",
        "mat_mumps_icntl_24")


@pytest.fixture
def options():
    """The PETSc options database with KEYS cleared, restored afterwards."""
    yield from cleared_petsc_options(KEYS)


def _laplacian(n: int) -> PETSc.Mat:
    """The 5-point Laplacian on an n x n grid (SPD, (n^2, n^2))."""
    k = PETSc.Mat().createAIJ([n * n, n * n], nnz=5, comm=PETSc.COMM_SELF)
    for i in range(n):
        for j in range(n):
            row = i * n + j
            k.setValue(row, row, 4.0)
            for di, dj in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                if 0 <= i + di < n and 0 <= j + dj < n:
                    k.setValue(row, (i + di) * n + j + dj, -1.0)
    k.assemble()
    return k


def _solve(options, settings: dict[str, str]) -> tuple[LinearSolver, float]:
    """A LinearSolver with `settings` on a 30 x 30 Laplacian, one solve of a random load
    with refine=True:
    (the solver, the relative residual |b - K x| / |b|)."""
    for key, value in settings.items():
        options.setValue(key, value)
    k = _laplacian(30)
    solver = LinearSolver(k)
    solver.factor()
    b = k.createVecLeft()
    b.setArray(np.random.default_rng(3).standard_normal(b.getLocalSize()))
    x = solver.solve(b, refine=True)
    r = b.duplicate()
    k.mult(x, r)
    r.aypx(-1.0, b)
    return solver, r.norm() / b.norm()


def test_an_iterative_solve_at_the_default_tolerance_is_refined_to_round_off(options):
    solver, rel = _solve(options, {"ksp_type": "gmres", "pc_type": "bjacobi",
                                   "ksp_rtol": "1e-12"})
    assert solver.refinable and rel <= REFINED_RESIDUAL
    assert solver.accuracy_warning() is None


def test_a_looser_user_tolerance_is_kept_and_warned_about(options):
    solver, rel = _solve(options, {"ksp_type": "cg", "pc_type": "jacobi", "ksp_rtol": "1e-6"})
    assert not solver.refinable and LOOSE_RESIDUAL < rel <= 1e-6
    text = solver.accuracy_warning()
    assert text is not None and "(-ksp_rtol 1e-06)" in text and "lower -ksp_rtol" in text


def test_an_inaccurate_solve_names_the_absolute_tolerance_that_stopped_it(options):
    with pytest.raises(SolveError, match=r"-ksp_atol 0\.1\): lower -ksp_atol"):
        _solve(options, {"ksp_type": "cg", "pc_type": "jacobi", "ksp_rtol": "1e-12",
                         "ksp_atol": "0.1"})


def _rhs(k: PETSc.Mat, size: float) -> PETSc.Vec:
    """A random right-hand side of 2-norm `size`."""
    b = k.createVecLeft()
    b.setArray(np.random.default_rng(5).standard_normal(b.getLocalSize()))
    b.scale(size / b.norm())
    return b


def test_a_round_off_right_hand_side_below_the_absolute_tolerance_is_solved_by_zero(options):
    """After a load of norm 20, a right-hand side of norm 2e-12 (round-off of it) under
    -ksp_atol 1e-12 (on the Jacobi-preconditioned residual, |b| / 4): PETSc returns x = 0,
    which is accepted without a warning; before, `relative residual 1.00e+00 > 1e-06,
    -ksp_atol 1e-12`."""
    solver, _ = _solve(options, {"ksp_type": "cg", "pc_type": "jacobi", "ksp_rtol": "1e-12",
                                 "ksp_atol": "1e-12"})
    solver.solve(_rhs(solver.k, 20.0), refine=True)
    x = solver.solve(_rhs(solver.k, 2e-12))
    assert x.norm() == 0.0
    assert solver.worst_residual < LOOSE_RESIDUAL and solver.accuracy_warning() is None
    solver.solve(_rhs(solver.k, 5e-16), scale=1.0)  # a round-off compliance column


def test_a_small_real_right_hand_side_below_the_absolute_tolerance_still_stops(options):
    """|b| = 1e-8 of the loads is no round-off: x = 0 (-ksp_atol 1e-6 above |b|) is an
    error naming -ksp_atol, and so is the same column judged against unit forces."""
    solver, _ = _solve(options, {"ksp_type": "cg", "pc_type": "gamg", "ksp_rtol": "1e-12",
                                 "ksp_atol": "1e-6"})
    solver.solve(_rhs(solver.k, 20.0), refine=True)
    with pytest.raises(SolveError, match=r"relative residual 1\.00e\+00 .*lower -ksp_atol"):
        solver.solve(_rhs(solver.k, 2e-7))
    with pytest.raises(SolveError, match=r"-ksp_atol 1e-06\): lower -ksp_atol"):
        solver.solve(_rhs(solver.k, 2e-7), scale=1.0)


def test_a_failed_lcp_with_iterative_solves_says_how_to_tell_their_part():
    assert _iterative_hint(SimpleNamespace(iterative=False, worst_residual=0.0)) == ""
    hint = _iterative_hint(SimpleNamespace(iterative=True, worst_residual=3.5e-12))
    assert "relative residual up to 3.5e-12" in hint and "default MUMPS LU" in hint


def _states(out) -> list:
    return [[s["states"], s["interfaces"]["bond"]["normal_force"]]
            for s in read_summary(out)["steps"]]


@pytest.mark.parametrize("ranks", [1, 2])
def test_gmres_block_jacobi_completes_bonded_as_the_direct_solve(tmp_path, ranks):
    """Before, on 1 rank: `the contact problem could not be solved at step 16: Lemke ended
    with 'inaccurate'`, exit 2 (README, "More ranks than useful ..."); 2 ranks: the
    refinement's collective solves."""
    base = ["run", str(CONFIGS / "bonded.toml"), "--mesh-size", "0.8", "--quiet"]
    r = run_cli([*base, "--out", str(tmp_path / "it"), "-ksp_type", "gmres",
                 "-pc_type", "bjacobi"], ranks=ranks)
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr
    r = run_cli([*base, "--out", str(tmp_path / "lu")])
    assert r.returncode == 0, r.stderr
    it, lu = _states(tmp_path / "it"), _states(tmp_path / "lu")
    assert [s for s, _ in it] == [s for s, _ in lu]
    scale = max(abs(p) for _, p in lu)
    assert max(abs(a - b) for (_, a), (_, b) in zip(it, lu, strict=True)) <= 1e-10 * scale


@pytest.mark.parametrize(("scene", "size"), [("bonded", "0.8"), ("patch", "1.0")])
def test_an_absolute_tolerance_at_round_off_completes_as_the_direct_solve(tmp_path, scene,
                                                                          size):
    """-ksp_atol 1e-12 with cg + gamg: bonded.toml's recovery of round-off contact forces
    (step 16, |b| = 5.9e-12) and patch.toml's compliance column of a round-off row of G
    (|b| = 1.5e-16) came back as x = 0 and stopped the run (`relative residual 1.00e+00`)."""
    base = ["run", str(CONFIGS / f"{scene}.toml"), "--mesh-size", size, "--quiet"]
    r = run_cli([*base, "--out", str(tmp_path / "it"), "-ksp_type", "cg", "-pc_type", "gamg",
                 "-ksp_atol", "1e-12"])
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr
    r = run_cli([*base, "--out", str(tmp_path / "lu")])
    assert r.returncode == 0, r.stderr
    it, lu = read_summary(tmp_path / "it")["steps"], read_summary(tmp_path / "lu")["steps"]
    assert [s["states"] for s in it] == [s["states"] for s in lu]
    for key in ("max_contact_pressure", "strain_energy"):
        a, b = (np.array([s[key] for s in steps]) for steps in (it, lu))
        assert np.abs(a - b).max() <= 1e-9 * max(np.abs(b).max(), 1e-300), key


def test_a_loose_tolerance_that_changes_a_contact_state_is_warned_about(tmp_path):
    """-ksp_rtol 1e-6 (residuals up to 3.9e-7, accepted): step 15 of bonded.toml had a
    pair open instead of slipping, exit 0 and no warning. The block's balance then
    reaches 1.2e-6 (step 13): its warning names the solves as the cause."""
    r = run_cli(["run", str(CONFIGS / "bonded.toml"), "--mesh-size", "0.8", "--quiet",
                 "--out", str(tmp_path), "-ksp_type", "cg", "-pc_type", "gamg",
                 "-ksp_rtol", "1e-6"])
    assert r.returncode == 0, r.stderr
    lines = [x for x in r.stderr.splitlines() if x.startswith("warning: ")]
    assert len(lines) == 2 and "(-ksp_rtol 1e-06)" in lines[0], lines
    assert "out of balance" in lines[1] and "iterative linear solves" in lines[1], lines
    assert any("relative residual" in w for w in read_summary(tmp_path)["warnings"])


def test_cg_with_an_indefinite_preconditioner_is_not_told_to_raise_max_it(tmp_path):
    """multibody.toml with -ksp_type cg -pc_type ilu: CG stops after 2 iterations on the
    indefinite ILU(0) (DIVERGED_INDEFINITE_PC); before, the line said `raise -ksp_max_it`."""
    r = run_cli(["run", str(CONFIGS / "multibody.toml"), "--mesh-size", "0.8", "--quiet",
                 "--out", str(tmp_path), "-ksp_type", "cg", "-pc_type", "ilu"])
    assert r.returncode == 2
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("error: ") and "DIVERGED_INDEFINITE_PC" in line
    assert "-pc_type ilu is not one" in line and "-ksp_max_it" not in line


def test_a_small_load_with_a_large_history_is_judged_against_the_forces_it_applies(tmp_path):
    """The cantilever with an extra axial load of 1e-13 at history [1e13] (a unit force):
    -ksp_atol 1e-12 solves its unit case as x = 0 (|b| below the tolerance). That case was
    judged against the other cases' |b| at factor 1, so x = 0 passed as round-off and the
    run completed without the axial load (strain energy 1.8144 for 1.8189 at
    --mesh-size 0.25); judged against the forces the steps apply it is an error naming
    -ksp_atol, and the direct solve carries the load as an axial force of 1 does."""
    text = (CONFIGS / "cantilever.toml").read_text()
    extra = '\n[[load]]\non = "tip_edge"\ntraction = [{0}, 0.0]\nhistory = [{1}]\n'
    (tmp_path / "tiny.toml").write_text(text + extra.format("1e-13", "1e13"))
    (tmp_path / "unit.toml").write_text(text + extra.format("1.0", "1.0"))
    base = ["--mesh-size", "0.5", "--quiet"]
    r = run_cli(["run", str(tmp_path / "tiny.toml"), *base, "--out", str(tmp_path / "it"),
                 "-ksp_type", "cg", "-pc_type", "jacobi", "-ksp_atol", "1e-12"])
    assert r.returncode == 2, r.stderr
    assert "-ksp_atol" in r.stderr and read_summary(tmp_path / "it")["status"] == "failed"
    energy = []
    for name in ("tiny", "unit"):
        r = run_cli(["run", str(tmp_path / f"{name}.toml"), *base, "--out",
                     str(tmp_path / name)])
        assert r.returncode == 0, r.stderr
        energy.append(read_summary(tmp_path / name)["steps"][-1]["strain_energy"])
    assert energy[0] == pytest.approx(energy[1], rel=1e-9)


def test_a_case_is_judged_against_the_forces_of_the_steps_it_acts_in():
    """case_scales: a load acting together with large ones is judged against their
    forces; the same load acting in a step of its own is judged against its own size
    (judged against the run's largest forces, a residual of 5e-4 of a traction of 0.38
    would pass as round-off of a clamp's 3.2e9 applied in another step)."""
    loads = [np.full(4, 3.2e9 / 2), np.full(4, 0.38 / 2)]
    together, run = case_scales(loads, [np.array([1.0, 1.0]), np.array([1.0, 1.0])])
    assert together == pytest.approx([3.2e9, 3.2e9]) and run == pytest.approx(3.2e9)
    apart, run = case_scales(loads, [np.array([1.0, 0.0]), np.array([0.0, 1.0])])
    assert apart == pytest.approx([3.2e9, 0.38]) and run == pytest.approx(3.2e9)
    tiny, _ = case_scales([np.full(4, 0.5), np.full(4, 5e-14)],
                          [np.array([1.0]), np.array([1e13])])  # 1e-13 x 1e13 = 1
    assert tiny == pytest.approx([1.0, 1e-13])
    idle, _ = case_scales(loads, [np.array([1.0, 1.0]), np.zeros(2)])
    assert idle == pytest.approx([3.2e9, 0.38])


def test_a_small_step_after_a_large_one_is_judged_against_its_own_forces(tmp_path):
    """hertz.toml (--mesh-size 2.0) in two steps, the load at 1 then 1e-8, under cg + gamg
    with -ksp_atol 1e-10 on the true residual: the second step's recovery (|G^T lam| =
    1.2e-5) stops at a residual of 9.7e-11, 8e-6 of its own forces. Judged against the
    run's largest forces (432: round-off up to 4.3e-10) it passed, and the run completed
    with step 2's strain energy off by 8e-7 and no warning; judged against the step's
    own forces it is an error naming -ksp_atol. The direct solve completes."""
    base = ["run", str(CONFIGS / "hertz.toml"), "--mesh-size", "2.0", "--quiet",
            "--set", "analysis.steps=2", "--set", "load.0.history=[1.0,1e-8]"]
    r = run_cli([*base, "--out", str(tmp_path / "it"), "-ksp_type", "cg", "-pc_type", "gamg",
                 "-ksp_norm_type", "unpreconditioned", "-ksp_atol", "1e-10"])
    assert r.returncode == 2, r.stderr
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("error: iterative linear solve is inaccurate"), line
    assert "-ksp_atol 1e-10): lower -ksp_atol" in line
    s = read_summary(tmp_path / "it")
    assert s["status"] == "failed" and len(s["steps"]) == 1  # step 1 written, step 2 not
    r = run_cli([*base, "--out", str(tmp_path / "lu")])
    assert r.returncode == 0, r.stderr


def test_step_force_scales_are_each_steps_own():
    """T(t) per step: the largest load case's forces at that step (0 where none acts)."""
    loads = [np.full(4, 3.2e9 / 2), np.full(4, 0.38 / 2)]
    steps = step_force_scales(loads, [np.array([1.0, 0.0, 0.0]), np.array([1.0, 1.0, 0.0])],
                              3)
    assert steps == pytest.approx([3.2e9, 0.38, 0.0])
    assert step_force_scales([], [], 2) == [0.0, 0.0]


def test_a_step_without_load_is_judged_against_the_runs_forces(tmp_path):
    """two_blocks.toml pressed at step 1 and unloaded at step 2 (T = 0) under cg + gamg
    with -ksp_atol 1e-12: step 2's contact forces are round-off, which the KSP solves as
    x = 0 (relative residual 1). Judged against the step's own forces, 0, that stopped the
    run; a step that applies no forces is judged against the run's largest, as before."""
    r = run_cli(["run", str(CONFIGS / "two_blocks.toml"), "--quiet", "--out", str(tmp_path),
                 "--set", "analysis.steps=2", "--set", "load.0.history=[1.0,0.0]",
                 "--set", "interface.interface.mu=0.3", "-ksp_type", "cg", "-pc_type", "gamg",
                 "-ksp_atol", "1e-12"])
    assert r.returncode == 0, r.stderr
    s = read_summary(tmp_path)
    assert s["status"] == "completed" and len(s["steps"]) == 2
    assert s["steps"][1]["strain_energy"] < 1e-12 * s["steps"][0]["strain_energy"]
