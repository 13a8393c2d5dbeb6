"""app/user_paths.py: a path the user gave that the system cannot look up (a name longer
than the file system allows) is a one-line error, not an OSError traceback."""

from __future__ import annotations

import pytest
from support import CONFIGS, read_summary, run_cli

from app.errors import InputError
from app.user_paths import path_kind

LONG = "n" * 300  # above NAME_MAX (255) of every Linux file system


def test_path_kind(tmp_path):
    (tmp_path / "f").write_text("x")
    assert path_kind(tmp_path / "f", "x") == "file"
    assert path_kind(tmp_path, "x") == "dir"
    assert path_kind("/dev/null", "x") == "other"
    assert path_kind(tmp_path / "missing", "x") is None
    assert path_kind(tmp_path / "f" / "below_a_file", "x") is None
    with pytest.raises(InputError, match=r"^--out '.*\.\.\..*': File name too long$"):
        path_kind(tmp_path / LONG, "--out")


def test_overlong_names_on_the_command_line(tmp_path):
    """Before: `OSError: [Errno 36] File name too long` tracebacks, exit 1 (found by
    scripts/fuzz_inputs.py)."""
    for args, what in [([str(CONFIGS / "patch.toml"), "--out", str(tmp_path / LONG)], "--out"),
                       ([str(tmp_path / f"{LONG}.toml"), "--out", str(tmp_path / "o")],
                        "config file")]:
        res = run_cli(["run", *args, "--quiet"])
        assert res.returncode == 2, res.stderr
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"error: {what} '"), res.stderr
        assert lines[0].endswith("File name too long")
    assert read_summary(tmp_path / "o")["status"] == "failed"  # the config's failure
