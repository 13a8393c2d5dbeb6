"""Bodies held only by contact (`app.interface.floating`): how many zero-energy modes they
may have, the pins of their modes (`pivot_rows`) and the amplitudes `rigid_modes` those
define, the same on 1 and 2 ranks. Before, LAPACK's column pivoting
split the equal-norm rows of a mirror-symmetric mesh by round-off, and the eigen-solver's
basis of the 1SD null space was arbitrary: hard/floating_gravity.toml with --sd 1 had
`rigid_modes` 1.81 (then 0.475 with the basis fixed) apart between 1 and 2 ranks, with
the displacements equal to 7e-14."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sps
from support import CONFIGS, ROOT, mpi_env, read_summary, run_cli

from app.interface.floating import _rank_keepers, pivot_rows


def test_pivot_rows_chooses_as_lapack_on_distinct_rows():
    a = np.random.default_rng(3).standard_normal((40, 6))
    piv, d = pivot_rows(a)
    _, rr, lapack = sla.qr(a.T, pivoting=True, mode="economic")
    np.testing.assert_array_equal(piv, lapack[:6])
    np.testing.assert_allclose(d, np.abs(np.diag(rr)), rtol=1e-12)


def test_tied_rows_go_to_the_lowest_whatever_the_round_off():
    """Rows 1 and 3 have equal norm to within 1e-13 (a mirror pair): row 1, whichever
    side of it the round-off falls."""
    base = np.array([[0.1, 0.0], [0.8, 0.6], [0.0, 0.2], [0.8, -0.6]])
    for eps in (1e-13, -1e-13):
        a = base.copy()
        a[3] *= 1.0 + eps
        assert pivot_rows(a)[0][0] == 1


def test_rank_keepers_break_ties_as_the_pins_do():
    """`_rank_keepers` chooses by the pins' rule (`pivot_rows`: ties to the lowest DOF).
    A contact row on four DOFs of a body, equal to round-off (a mirror-symmetric mesh):
    one DOF keeps its rank, DOF 10 whichever entry the round-off makes largest. Before,
    LAPACK's pivoted QR took the largest, DOF 11, 12 or 13 as the round-off fell."""
    dofs = np.array([10, 11, 12, 13])
    keepers = []
    for k in range(4):
        row = np.ones(4)
        row[k] *= 1.0 + 4e-16 * (k > 0)
        g = sps.csr_matrix((row, (np.zeros(4, dtype=int), dofs)), shape=(1, 16))
        keep = _rank_keepers(g, dofs, None, np.zeros(4, dtype=bool))
        keepers.append(dofs[keep].tolist())
    assert keepers == [[10]] * 4


@pytest.mark.mpi
def test_hourglass_amplitudes_agree_on_one_and_two_ranks(tmp_path):
    """The 1-rank run with two BLAS threads (a plain `python -m app run` on this 2-core
    machine), the 2-rank one with one each: their round-off differs, the pins may not."""
    args = ["run", str(CONFIGS / "hard" / "floating_gravity.toml"), "--sd", "1", "--quiet"]
    env = dict(mpi_env(), OPENBLAS_NUM_THREADS="2", OMP_NUM_THREADS="2")
    r = subprocess.run([sys.executable, "-m", "app", *args, "--out", str(tmp_path / "r1")],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    r = run_cli([*args, "--out", str(tmp_path / "r2")], ranks=2)
    assert r.returncode == 0, r.stderr
    runs = [read_summary(tmp_path / f"r{k}")["steps"][-1]["rigid_modes"] for k in (1, 2)]
    one, two = runs
    assert len(one) == 6 and one.keys() == two.keys()
    a, b = np.array(list(one.values())), np.array(list(two.values()))
    assert np.abs(a - b).max() <= 1e-9 * np.abs(a).max(), (one, two)


def test_a_strip_one_element_thick_under_1sd_stops_early_with_one_line(tmp_path):
    """multibody.toml's block1 as 150 x 1 elements has 154 zero-energy modes under
    CS-FEM-1SD. Before, the run spent 5.5 s finding them, then Lemke ended 'inaccurate'
    (12 s in all); at 600 x 1, 380 s in the eigen-solve, then an exception."""
    r = run_cli(["run", str(CONFIGS / "multibody.toml"), "--sd", "1", "--set",
                 "body.block1.shape.divisions=[150,1]", "--out", str(tmp_path), "--quiet"])
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: body 'block1' has more than 32 "
                                                   "zero-energy modes (at least 64)"), lines
    assert "--sd 2" in lines[0] and "fem-q4" in lines[0] and "Traceback" not in r.stderr
    summary = read_summary(tmp_path)
    assert summary["status"] == "failed" and "block1" in summary["error"]
