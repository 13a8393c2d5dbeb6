"""Bounds on what a config file holds (app/config.py): integers within TOML's 64 bits,
at most MAX_CONFIG_BYTES.

Before, `E = 0x` followed by 5000 `f` ended in `OverflowError: int too large to convert to
float`, `E = 1` followed by 5000 zeros in tomllib's `ValueError: Exceeds the limit (4300
digits) for integer string conversion`, and `--set body.99...9.E=1` (5000 nines) or
`--set body.².E=1` in the same ValueError from the index: tracebacks, exit 1. A config
file had no size bound: 200,000 `[[mesh.refine]]` points (4.4 MB) ran 25 s and 488 MB.
"""

import pytest
from support import CONFIGS, read_summary, run_cli

from app.config import MAX_CONFIG_BYTES, load_config
from app.errors import InputError

PATCH = (CONFIGS / "patch.toml").read_text()


def _refused(tmp_path, old: str, new: str, match: str) -> None:
    """patch.toml with its first `old` replaced by `new` is refused at load with `match`."""
    path = tmp_path / "c.toml"
    path.write_text(PATCH.replace(old, new, 1))
    with pytest.raises(InputError, match=match):
        load_config(path)


@pytest.mark.parametrize("old, new, match", [
    ("E = 1000.0", "E = 0x" + "f" * 5000, r"body\.0\.E is an integer of 20000 bits"),
    ("E = 1000.0", "E = 1" + "0" * 5000, r"an integer of more than 19 digits"),
    ("E = 1000.0", "E = 9223372036854775808", r"body\.0\.E is an integer of 64 bits, beyond "
     r"TOML's 64-bit signed integers \(-2\^63 \.\. 2\^63 - 1\)"),  # (read "64 bits: ... 64-bit")
    ("E = 1000.0", "E = -9223372036854775809", r"E is an integer of 64 bits, beyond"),
    ("pressure = 10.0", 'pressure = "P"\n[parameters]\nP = 0x' + "f" * 300,
     r"parameters\.P is an integer of 1200 bits"),
])
def test_a_config_file_integer_beyond_64_bits_is_refused(tmp_path, old, new, match):
    _refused(tmp_path, old, new, match)


def test_the_largest_64_bit_integer_is_accepted(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(PATCH.replace("E = 1000.0", "E = 9223372036854775807", 1))
    assert load_config(path).E[0] == 9223372036854775807.0
    path.write_text(PATCH.replace("E = 1000.0", "E = 210000000000", 1))  # steel in Pa
    assert load_config(path).E[0] == 2.1e11


@pytest.mark.parametrize("item, match", [
    ("body.lower.E=0x" + "f" * 5000, r"--set: body\.0\.E is an integer of 20000 bits"),
    ("body.lower.E=1" + "0" * 5000, r"an integer of more than 19 digits"),
    ("body." + "9" * 5000 + ".E=1", r"no entry '9999"),
    ("body.\u00b2.E=1", r"no entry '\u00b2'"),
])
def test_a_set_integer_or_index_beyond_64_bits_is_refused(item, match):
    with pytest.raises(InputError, match=match):
        load_config(CONFIGS / "patch.toml", [item])


def test_the_run_fails_in_one_line(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text(PATCH.replace("E = 1000.0", "E = 0x" + "f" * 5000, 1))
    res = run_cli(["run", str(path), "--out", str(tmp_path / "o"), "--quiet"])
    assert res.returncode == 2 and res.stderr.startswith("error: config file"), res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert read_summary(tmp_path / "o")["status"] == "failed"


def test_a_config_file_larger_than_the_bound_is_refused(tmp_path):
    path = tmp_path / "c.toml"
    pad = "# " + "x" * 98 + "\n"
    path.write_text(PATCH + pad * (MAX_CONFIG_BYTES // len(pad)))
    with pytest.raises(InputError, match=r"larger than 4 MB"):
        load_config(path)
    path.write_text(PATCH + pad * (MAX_CONFIG_BYTES // len(pad) - 100))  # just below
    assert load_config(path).body_names == ["lower", "upper"]


def test_a_latin1_file_is_still_named_as_not_utf8(tmp_path):
    path = tmp_path / "c.toml"
    path.write_bytes(PATCH.encode() + b'title = "\xe9"\n')
    with pytest.raises(InputError, match=r"is not UTF-8 text \(byte"):
        load_config(path)


@pytest.mark.parametrize("old, new, match", [
    ('name = "interface"', 'name = "if\\u001b[2J\\u202eevil"',
     r"interface\.0\.name contains the control character U\+001B"),
    ('on = "upper_top"', 'on = "upper_top\\u001b]0;title\\u0007"', r"load\.0\.on .* U\+001B"),
    ('name = "upper"', 'name = "up\\u202eper"', r"body\.1\.name .* U\+202E"),
    ('name = "upper"', 'name = """up\nper"""', r"body\.1\.name .* U\+000A"),
    ("[[support]]", '[points]\n"p\\u0000" = [0.0, 0.0]\n[[support]]', r"the key 'points.p\\x00'"),
])
def test_control_characters_in_names_and_keys_are_refused(tmp_path, old, new, match):
    _refused(tmp_path, old, new, match)


def test_a_title_or_expression_may_span_lines_and_a_name_hold_a_tab(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text('title = """Patch\ntest"""\n' + PATCH.replace(
        'name = "upper"', 'name = "up\\tper"').replace('ux = 0.0', 'ux = """(0.0\n* x)"""', 1))
    assert load_config(path).body_names == ["lower", "up\tper"]


def test_an_escape_sequence_in_a_name_never_reaches_the_terminal(tmp_path):
    """Before: exit 0, and the progress line `step 1/1; ...; if<ESC>[2J<RLO>evil F=...`
    cleared the terminal and reversed the rest of the line."""
    path = tmp_path / "c.toml"
    path.write_text(PATCH.replace('name = "interface"', 'name = "if\\u001b[2J\\u202eevil"'))
    res = run_cli(["run", str(path), "--out", str(tmp_path / "o")])
    assert res.returncode == 2 and "\x1b" not in res.stderr + res.stdout, res.stderr
    assert read_summary(tmp_path / "o")["status"] == "failed"


@pytest.mark.parametrize("key", ["body", "interface", "support", "load"])
def test_too_many_entries_is_one_line_before_anything_is_built(key):
    """Before: no bound; 5000 bodies, supports and loads meshed and set up for 47 s before
    a wrong support's group was reported (in a 111 kB line listing every curve)."""
    import tomllib

    from app.config import MAX_ENTRIES, parse_config

    raw = tomllib.loads(PATCH)
    most = MAX_ENTRIES[key]
    entry = raw[key][0]
    raw[key] = [dict(entry) for _ in range(most + 1)]
    with pytest.raises(InputError, match=rf"^\[\[{key}\]\] has {most + 1} entries, more "
                                         rf"than {most}: split the scene"):
        parse_config(raw)
    raw[key] = raw[key][:most]
    try:
        parse_config(raw)  # other checks may refuse the copies (the same body name twice)
    except InputError as exc:
        assert "entries, more than" not in str(exc)


def test_too_many_bodies_in_a_run_fails_with_a_summary(tmp_path):
    body = PATCH[PATCH.index("[[body]]"):PATCH.index("[[body]]", PATCH.index("[[body]]") + 1)]
    cfg = tmp_path / "many.toml"
    cfg.write_text(PATCH + "\n" + body * 1001)
    out = tmp_path / "o"
    res = run_cli(["run", str(cfg), "--out", str(out), "--quiet"], timeout=120)
    assert res.returncode == 2
    assert res.stderr.strip() == ("error: [[body]] has 1003 entries, more than 1000: split "
                                  "the scene into smaller ones"), res.stderr
    assert read_summary(out)["status"] == "failed"


def test_a_utf8_byte_order_mark_is_read_and_utf16_and_utf32_are_named(tmp_path):
    """Before: a UTF-8 BOM (Windows editors) read as `not valid TOML: Invalid statement
    (at line 1, column 1)`, and UTF-16 as `not UTF-8 text (byte 0)`; then UTF-32 LE read as
    UTF-16."""
    cfg = tmp_path / "bom.toml"
    cfg.write_bytes(b"\xef\xbb\xbf" + PATCH.encode())
    assert load_config(cfg).body_names == ["lower", "upper"]
    out = tmp_path / "o"
    res = run_cli(["run", str(cfg), "--out", str(out), "--quiet", "--mesh-size", "0.5"],
                  timeout=120)
    assert res.returncode == 0, res.stderr
    assert read_summary(out)["status"] == "completed"
    for encoding in ("utf-16", "utf-16-be"):
        text = PATCH.encode(encoding)
        cfg.write_bytes(text if encoding == "utf-16" else b"\xfe\xff" + text)
        with pytest.raises(InputError, match=r"is UTF-16 text \(it starts with a UTF-16 "
                                             r"byte order mark\): save it as UTF-8$"):
            load_config(cfg)
    for encoding in ("utf-32", "utf-32-be"):  # UTF-32 LE's mark starts as UTF-16 LE's
        text = PATCH.encode(encoding)
        cfg.write_bytes(text if encoding == "utf-32" else b"\x00\x00\xfe\xff" + text)
        with pytest.raises(InputError, match=r"is UTF-32 text \(it starts with a UTF-32 "
                                             r"byte order mark\): save it as UTF-8$"):
            load_config(cfg)
