"""A contact too large for the dense matrices of the condensation is refused in one line
once the pairs are known, before the factorization (app/condensation/dense_size.py).
Before, the size check counted elements only: a thin body with a long contact passed it,
and the Schur complement's allocation failed with a numpy traceback (exit 1) after a
minute, or the machine ran out of memory."""

import numpy as np
import pytest
import scipy.sparse as sp
from support import CONFIGS, read_summary, run_cli

from app.condensation import dense_size
from app.condensation.dense_size import check_dense_contact, free_contact_dofs
from app.errors import InputError


def test_the_dense_size_counts_free_contact_dofs_and_rows():
    g = sp.csr_matrix(np.array([[1.0, -1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0, 0.0]]))
    assert free_contact_dofs(g, np.array([1])) == 2  # columns 0 and 2; 1 is prescribed
    assert dense_size.dense_contact_bytes(2, 2) == pytest.approx(24.0 * 8 + 8.0 * 4)
    with pytest.raises(InputError, match="1 pairs on 2 free DOFs.*--allow-large"):
        check_dense_contact(g, np.array([1]), 0.0, available=100.0)
    assert check_dense_contact(g, np.array([1]), 0.0, 100.0, allow_large=True) == 224.0
    assert check_dense_contact(g, np.array([1]), 0.0, 1e9) == 224.0


def test_the_dense_size_counts_the_recovery_s_kept_columns():
    # they stay through the steps (n_c x 2m doubles when every row fits); before, the
    # estimate left them out and cattaneo_many's peak passed it
    from app.condensation.contact_columns import ContactColumns

    n_c, n_rows = 6000, 4000
    cols = ContactColumns(sp.csr_matrix((n_rows, n_c)), lambda b: b)
    kept = 8.0 * n_c * cols.max_columns
    assert cols.max_columns == n_rows
    assert dense_size.dense_contact_bytes(n_c, n_rows) == pytest.approx(
        24.0 * (n_c ** 2 + n_rows ** 2) + kept)


def test_a_long_thin_contact_is_refused_before_the_factorization(tmp_path):
    out = tmp_path / "o"
    res = run_cli(["run", str(CONFIGS / "patch.toml"), "--out", str(out), "--quiet",
                   "--set", "body.lower.shape.divisions=[16000,1]",
                   "--set", "body.upper.shape.divisions=[16000,1]"], timeout=120)
    assert res.returncode == 2, res.stderr[-800:]
    assert len(res.stderr.strip().splitlines()) == 1
    assert "16001 pairs on 64000 free DOFs" in res.stderr and "GB" in res.stderr
    s = read_summary(out)
    assert s["status"] == "failed" and "factorization" not in s.get("timings", {})
