"""The mixed-integer search for a complementary basis (`app.lcp.mip`): where Lemke's method
ends on a secondary ray though the LCP has a solution (its matrix not copositive-plus, as
the frictional contact LCP with free floating-mode amplitudes), the search finds a basis,
and Lemke warm-started from it solves and checks the answer."""

from __future__ import annotations

import os
import time

import numpy as np

from app.lcp import lemke, mip
from app.lcp.mip import MIP_MAX_SIZE, complementary_basis


def test_a_solution_that_lemke_misses_is_found():
    """z = (0, 2/3, 1/2) solves it (w = (0, 0, 0)); Lemke ends on a secondary ray."""
    m = np.array([[0.0, 0.0, 2.0], [3.0, -3.0, -2.0], [2.0, 3.0, -2.0]])
    q = np.array([-1.0, 3.0, -1.0])
    assert lemke(m, q).status == "secondary ray"
    basis, text = complementary_basis(m, q)
    assert basis is not None, text
    res = lemke(m, q, basis=basis, cold_start=False)
    assert res.status == "solved"
    np.testing.assert_allclose(res.z, [0.0, 2.0 / 3.0, 0.5], atol=1e-12)


def test_no_solution_is_said_so():
    """w = -z - 1 < 0 for every z >= 0: no solution, the words give the bound searched."""
    basis, text = complementary_basis(np.array([[-1.0]]), np.array([-1.0]))
    assert basis is None and "found no solution" in text and "1e+03" in text


def test_a_large_lcp_is_not_searched():
    n = MIP_MAX_SIZE + 1
    basis, text = complementary_basis(np.eye(n), np.ones(n))
    assert basis is None and f"size {n}" in text


def test_a_widened_bound_admits_a_larger_unknown_of_its_own():
    """z = (1999, 1) solves w = (z1 - 1999 z2, z2 - 1): z1 is beyond the bound, 1e3 x max
    |q| = 1e3, and found with widen = 3 on it."""
    m, q = np.array([[1.0, -1999.0], [0.0, 1.0]]), np.array([0.0, -1.0])
    assert complementary_basis(m, q)[0] is None
    assert complementary_basis(-np.eye(2), -np.ones(2), widen=np.array([3.0, 1.0]))[1] == (
        "a mixed-integer search found no solution with the scaled unknowns below 1e+03 x the"
        " largest constant term (1 of them up to 3.0e+03)")  # (w = -z - 1: none at all)
    basis, text = complementary_basis(m, q, widen=np.array([3.0, 1.0]))
    assert basis is not None and basis.all(), text
    res = lemke(m, q, basis=basis, cold_start=False)
    assert res.status == "solved"
    np.testing.assert_allclose(res.z, [1999.0, 1.0], rtol=1e-12)


def test_the_verdict_and_the_basis_do_not_depend_on_the_units():
    """LCP(m, t q) has the solutions t z (t > 0): a scene in other units (every E, load and
    bond strength x t^2 scales the unit-diagonal q by t) is the same search. Before, the
    bound applied to the unknowns as they came: at t = 1e4 the solution (z3 = 5e3) lay
    beyond 1e3 and the search found none, and at t = 1e-7 its z (5e-8) read as 0 against
    the fixed threshold, a basis of all w (multibody.toml --sd 1 --mesh-size 1.2 with its
    moduli, loads and bond strengths x 1e6 stopped with `no static equilibrium`)."""
    m = np.array([[0.0, 0.0, 2.0], [3.0, -3.0, -2.0], [2.0, 3.0, -2.0]])
    q = np.array([-1.0, 3.0, -1.0])
    for t in (1e-7, 1.0, 1e4):
        basis, text = complementary_basis(m, t * q)
        assert basis is not None and basis.tolist() == [False, True, True], (t, text)
        res = lemke(m, t * q, basis=basis, cold_start=False)
        assert res.status == "solved" and res.pivots == 0, t
        np.testing.assert_allclose(res.z, t * np.array([0.0, 2.0 / 3.0, 0.5]), rtol=1e-12)


def _small_lcp() -> tuple[np.ndarray, np.ndarray]:
    return np.array([[1.0, -2.0], [-2.0, 1.0]]), np.array([-1.0, -1.0])


def test_a_crash_of_highs_ends_the_search_not_the_run(monkeypatch):
    """scipy 1.10's HiGHS aborted in free() on two_blocks.toml's LCP of 39 at E = 1e13
    (README "Floating bodies"): the whole run died with summary.json `running`. Every
    bound crashing alike: the words say so once (before: the crash's words once per bound,
    each with an empty `exit -6: `)."""
    monkeypatch.setattr(mip, "_CHILD", "import os; os.abort()")
    basis, found = complementary_basis(*_small_lcp())
    assert basis is None
    assert found == ("a mixed-integer search found none below 1e+01, 1e+02 or 1e+03 "
                     "(HiGHS crashed (exit -6))"), found
    monkeypatch.setattr(mip, "_CHILD", "import os, sys; print('free(): invalid pointer', "
                                       "file=sys.stderr); os.abort()")
    assert complementary_basis(*_small_lcp())[1].endswith(
        "or 1e+03 (HiGHS crashed (exit -6: free(): invalid pointer))")


def _crashing_first(tmp_path) -> str:
    """The search process's code, made to abort the first time it runs (a flag file under
    tmp_path), as scipy 1.10's HiGHS did on one bound of one LCP."""
    flag = str(tmp_path / "crashed")
    return (f"import os\nif not os.path.exists({flag!r}):\n    open({flag!r}, 'w').close()\n"
            f"    os.abort()\n") + mip._CHILD


def test_a_crash_at_one_bound_goes_on_to_the_next(tmp_path, monkeypatch):
    """Before, HiGHS's crash at the first bound (10) ended the search without a basis,
    though the next bound (100) finds one: two_blocks.toml's E = 1e13 mortar step 3
    stopped on the crash alone (README "Floating bodies"). Now the next bound is searched
    and its basis solves; the words name the crash."""
    m = np.array([[0.0, 0.0, 2.0], [3.0, -3.0, -2.0], [2.0, 3.0, -2.0]])
    q = np.array([-1.0, 3.0, -1.0])
    monkeypatch.setattr(mip, "_CHILD", _crashing_first(tmp_path))
    basis, found = complementary_basis(m, q)
    assert basis is not None, found
    assert found.startswith("a mixed-integer search found a basis (the scaled unknowns "
                            "below 1e+02 x the largest constant term), after none below "
                            "1e+01 (HiGHS crashed (exit -6"), found
    res = lemke(m, q, basis=basis, cold_start=False)
    assert res.status == "solved"
    np.testing.assert_allclose(res.z, [0.0, 2.0 / 3.0, 0.5], atol=1e-12)


def test_a_crash_goes_on_only_within_the_time_left(tmp_path, monkeypatch):
    """A crash that leaves less than a second of the search's time ends it (`no time
    left`), and a time limit still ends the search at its bound."""
    monkeypatch.setattr(mip, "_CHILD", "import os, time; time.sleep(1.5); os.abort()")
    basis, found = complementary_basis(*_small_lcp(), seconds=2.0)
    assert basis is None
    assert found.endswith("(HiGHS crashed (exit -6)), then no time left"), found
    assert found.count("crashed") == 1, found
    monkeypatch.setattr(mip, "_CHILD", "import time; time.sleep(60)")
    monkeypatch.setattr(mip, "MIP_GRACE", 0.5)
    basis, found = complementary_basis(*_small_lcp(), seconds=1.0)
    assert found.count("HiGHS passed its time limit") == 1, found


def test_a_search_process_stopped_from_outside_ends_the_search(monkeypatch):
    """SIGTERM, SIGKILL (a user, a job's end, the out-of-memory killer) end the search at
    the first bound, its words naming the signal (before: `none before its limit (HiGHS
    crashed (exit -9: ))`, neither a limit nor a crash); SIGSEGV (HiGHS's own crash) goes
    on to the next."""
    for sig, code in (("SIGTERM", -15), ("SIGKILL", -9)):
        monkeypatch.setattr(mip, "_CHILD", f"import os, signal; os.kill(os.getpid(), "
                                           f"signal.{sig})")
        basis, found = complementary_basis(*_small_lcp())
        assert basis is None and found == (
            f"a mixed-integer search found none below 1e+01 (HiGHS was stopped by {sig} "
            f"from outside (exit {code}))"), found
    monkeypatch.setattr(mip, "_CHILD", "import os, signal; os.kill(os.getpid(), "
                                       "signal.SIGSEGV)")
    assert complementary_basis(*_small_lcp())[1] == (
        "a mixed-integer search found none below 1e+01, 1e+02 or 1e+03 (HiGHS crashed "
        "(exit -11))")


def test_the_step_bounds_the_search_when_every_bound_crashes(monkeypatch):
    """Each bound's HiGHS crashing 1.5 s in, within a step's 2 s: the search ends after
    the first (`no time left`), its words naming the step's budget (before: no reason)."""
    monkeypatch.setattr(mip, "CLOCK", mip.SearchClock())
    monkeypatch.setattr(mip, "MIP_STEP_SECONDS", 2.0)
    monkeypatch.setattr(mip, "_CHILD", "import os, time; time.sleep(1.5); os.abort()")
    t = time.monotonic()
    basis, found = complementary_basis(*_small_lcp())
    assert time.monotonic() - t < 3.0
    assert basis is None and found == (
        "a mixed-integer search found none below 1e+01 (HiGHS crashed (exit -6)), then no "
        "time left (this step's 2 s of searches are spent)"), found
    assert complementary_basis(*_small_lcp())[1] == \
        "no mixed-integer search (this step's 2 s of searches are spent)"


def test_a_search_past_its_time_limit_is_stopped(monkeypatch):
    """HiGHS checks its clock between LPs: one that does not return is killed MIP_GRACE
    past the limit."""
    monkeypatch.setattr(mip, "_CHILD", "import time; time.sleep(60)")
    monkeypatch.setattr(mip, "MIP_GRACE", 0.5)
    t = time.monotonic()
    basis, found = complementary_basis(*_small_lcp(), seconds=1.0)
    assert time.monotonic() - t < 5
    assert basis is None and "passed its time limit (1 s) by 0 s and was stopped" in found


def test_the_step_and_the_run_bound_the_searches_time(monkeypatch):
    """A run's searches stop at MIP_RUN_SECONDS, a step's at MIP_STEP_SECONDS (before,
    only each search had a limit, 600 s, and a step or a run could hold many)."""
    monkeypatch.setattr(mip, "CLOCK", mip.SearchClock())
    monkeypatch.setattr(mip, "MIP_STEP_SECONDS", 4.0)
    monkeypatch.setattr(mip, "MIP_RUN_SECONDS", 6.0)
    monkeypatch.setattr(mip, "_CHILD", "import time; time.sleep(60)")  # a search that hangs
    monkeypatch.setattr(mip, "MIP_GRACE", 0.5)
    t = time.monotonic()
    basis, found = complementary_basis(*_small_lcp())
    assert basis is None and "was stopped) (this step's 4 s of searches are spent)" in found, found
    assert 4.0 < time.monotonic() - t < 8.0
    assert complementary_basis(*_small_lcp())[1] == \
        "no mixed-integer search (this step's 4 s of searches are spent)"
    mip.CLOCK.new_step()
    basis, found = complementary_basis(*_small_lcp())
    assert "(this run's 6 s of searches are spent)" in found, found
    mip.CLOCK.new_step()
    assert complementary_basis(*_small_lcp())[1] == \
        "no mixed-integer search (this run's 6 s of searches are spent)"
    mip.CLOCK.new_run()
    assert complementary_basis(*_small_lcp(), seconds=0.5)[1].startswith(
        "a mixed-integer search found none before its limit (HiGHS passed")


def test_each_run_starts_with_the_whole_search_budget(tmp_path, monkeypatch):
    """A study or sweep runs many scenes in one process: each `app.run.run` resets the
    search clock (`SearchClock.new_run`), so one run's spent searches do not take the next
    run's budget (review8: nothing guarded the reset)."""
    import tomllib

    from support import CONFIGS

    from app.config import parse_config
    from app.run import RunOptions, run

    monkeypatch.setattr(mip.CLOCK, "run", mip.MIP_RUN_SECONDS)  # an earlier run spent it
    monkeypatch.setattr(mip.CLOCK, "step", mip.MIP_STEP_SECONDS)
    raw = tomllib.loads((CONFIGS / "bonded.toml").read_text())
    raw["analysis"]["steps"] = 1
    for s in raw["support"][1:]:
        s["history"] = s["history"][:1]
    summary = run(parse_config(raw, CONFIGS / "bonded.toml"),
                  RunOptions(out=tmp_path / "out", quiet=True))
    assert summary["status"] == "completed"
    assert mip.CLOCK.left() > min(mip.MIP_STEP_SECONDS, mip.MIP_RUN_SECONDS) - 60.0


def test_stray_output_of_the_search_process_is_not_taken_for_its_answer(tmp_path,
                                                                        monkeypatch):
    """The search process writes HiGHS's answer on its stdout. Before, anything else there
    (a sitecustomize's banner on the user's PYTHONPATH, a print from HiGHS's C code) made
    `pickle.loads` raise in the run: a traceback (review8). Now stray output goes to stderr
    and an answer that does not unpickle ends the search, not the run."""
    (tmp_path / "sitecustomize.py").write_text("print('a banner on stdout')\n")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        [str(tmp_path), *filter(None, [os.environ.get("PYTHONPATH")])]))
    basis, found = complementary_basis(np.eye(2), np.array([-1.0, 1.0]))
    assert basis is not None and basis.tolist() == [True, False], found
    monkeypatch.setattr(mip, "_CHILD", "print('not an answer')")
    basis, found = complementary_basis(*_small_lcp())
    assert basis is None and "HiGHS's answer unreadable (" in found, found
