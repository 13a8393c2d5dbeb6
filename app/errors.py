"""Errors the application reports to the user as one line (no traceback)."""

import re

LONG_WORD = 400
"""A run of non-blank characters in a message longer than this is shown cut in the middle
(a 5000-character value quoted back made a 5000-character error line)."""

MAX_MESSAGE = 1500
"""A longer message (many long words) keeps its first 1000 and last 300 characters."""

_LONG = re.compile(r"\S{" + str(LONG_WORD + 1) + ",}")


def cut_middle(text: str, head: int, tail: int) -> str:
    """`text` with all but its first `head` and last `tail` characters replaced by
    `...[N characters]...` (unchanged when that would not make it shorter)."""
    cut = len(text) - head - tail
    return text if cut <= 0 else f"{text[:head]}...[{cut} characters]...{text[-tail:]}"


def _cut(match: re.Match) -> str:
    return cut_middle(match.group(0), 200, 40)


class _OneLineError(Exception):
    """An error whose message is one line: line breaks and other control characters that
    came with a user's name or value are shown escaped ('\\n'), never as a line break, and
    a name or value longer than LONG_WORD characters (a message longer than MAX_MESSAGE) is
    cut in the middle."""

    def __str__(self) -> str:
        text = super().__str__()
        if not text.isprintable():
            text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
        text = _LONG.sub(_cut, text)
        if len(text) > MAX_MESSAGE:
            text = cut_middle(text, 1000, 300)
        return text


class InputError(_OneLineError):
    """Bad input (config, mesh, parameter): the message names the thing to fix."""


class SolveError(_OneLineError):
    """A solve that cannot give a right answer (singular stiffness, no equilibrium)."""
