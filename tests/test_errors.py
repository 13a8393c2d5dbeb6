"""app/errors.py: the user's errors are one line whatever names or values they quote."""

from __future__ import annotations

import pytest

from app.assembly.solve import SingularStiffnessError
from app.errors import InputError, SolveError


@pytest.mark.parametrize("cls", [InputError, SolveError, SingularStiffnessError])
def test_control_characters_in_a_message_are_escaped(cls):
    exc = cls("support on '\n': unknown group '\r\t' x")
    assert str(exc) == "support on '\\n': unknown group '\\r\\t' x"
    assert str(cls("plain é message")) == "plain é message"  # printable text untouched


@pytest.mark.parametrize("cls", [InputError, SolveError, SingularStiffnessError])
def test_a_long_value_in_a_message_is_cut(cls):
    """A 5000-character value quoted back made a 5000-character error line (found by
    scripts/fuzz_inputs.py); the key, the start and the end of the value stay."""
    value = "a" * 2500 + "b" * 2500
    text = str(cls(f"body 'block': shape.width must be a number > 0 (got {value!r})"))
    assert len(text) < 600
    assert text.startswith("body 'block': shape.width must be a number > 0 (got 'aaa")
    assert text.endswith("bbb')") and "[4763 characters]" in text
    many = str(cls("curves: " + " ".join(["c" * 300] * 40)))
    assert len(many) < 1500 and many.startswith("curves: ccc") and many.endswith("ccc")
    assert str(cls("x" * 400)) == "x" * 400  # short enough: untouched
