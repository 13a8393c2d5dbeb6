"""A study refused because another study holds OUT's lock (app/studies/batch_status.py)
writes nothing into OUT, even when that study ends and frees the lock before the refused
one records its failure. Before, the refused study's `failed` summary.json ("another run
is writing into this folder") replaced the other study's `completed` one: measured with
two `study configs/cantilever.toml` into one OUT, the second started as the first wrote
its plots."""

from __future__ import annotations

import fcntl
import json

import pytest
from support import CONFIGS

from app.errors import InputError
from app.studies.batch_status import BatchStatus


def test_a_refused_study_leaves_the_other_studys_summary(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    done = json.dumps({"command": "study", "study": "convergence", "status": "completed",
                       "config": "c.toml", "rows": 3})
    (out / "summary.json").write_text(done)
    with pytest.raises(InputError, match="another run is writing"):
        with BatchStatus("convergence", CONFIGS / "cantilever.toml", [], lambda: out) as b:
            other = open(out / ".lock", "a")  # the other study, still running
            fcntl.flock(other.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
            try:
                b.open(None)
            finally:
                other.close()  # it ends, between the refusal and the failure's record
    assert (out / "summary.json").read_text() == done
