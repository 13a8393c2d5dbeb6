"""A deeply nested TOML value (in the config file or a --set) is a one-line error, exit 2,
with summary.json failed; before, tomllib's RecursionError was a traceback, exit 1."""

from support import CONFIGS, read_summary, run_cli


def test_deep_nesting_is_one_line(tmp_path):
    deep = "[" * 3000 + "]" * 3000
    path = tmp_path / "deep.toml"
    path.write_text(f"title = {deep}\n" + (CONFIGS / "patch.toml").read_text())
    for n, args in enumerate([[str(path)],
                              [str(CONFIGS / "patch.toml"), "--set", f"title={deep}"]]):
        out = tmp_path / f"o{n}"
        res = run_cli(["run", *args, "--out", str(out), "--quiet"])
        assert res.returncode == 2, res.stderr[-500:]
        assert len(res.stderr.strip().splitlines()) == 1 and "too deeply" in res.stderr
        assert read_summary(out)["status"] == "failed"
