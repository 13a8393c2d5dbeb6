"""Errors the application reports to the user as one line (no traceback)."""


class _OneLineError(Exception):
    """An error whose message is one line: line breaks and other control characters that
    came with a user's name or value are shown escaped ('\\n'), never as a line break."""

    def __str__(self) -> str:
        text = super().__str__()
        if text.isprintable():
            return text
        return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


class InputError(_OneLineError):
    """Bad input (config, mesh, parameter): the message names the thing to fix."""


class SolveError(_OneLineError):
    """A solve that cannot give a right answer (singular stiffness, no equilibrium)."""
