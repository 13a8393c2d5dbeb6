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
