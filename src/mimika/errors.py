"""The exception tree. Every error a user can cause is a :class:`MimikaError`.

The CLI turns these into one line on stderr and exit code 2; messages say what was wrong,
where, and how to fix it.
"""


class MimikaError(Exception):
    """Root of every error mimika raises on purpose."""


class ParameterError(MimikaError, ValueError):
    """A parameter value is invalid (names the parameter, the value and what is expected)."""


class DataError(MimikaError):
    """A file or data set is missing or malformed (names the file and, where known, the line)."""


class RenderError(MimikaError):
    """Headless OpenGL is not available or failed."""
