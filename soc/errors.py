"""Errors vislod raises. Each subclasses ``ValueError`` or ``RuntimeError`` so callers can catch
broadly, and each message says what was wrong and how to fix it."""

from collections.abc import Sequence


class SceneError(ValueError):
    """A scene's geometry or layout is invalid (empty, non-finite, bad indices, bad shapes)."""


class SceneFormatError(SceneError):
    """A scene file is missing or does not follow its format."""


class GLUnavailableError(RuntimeError):
    """No headless OpenGL 4.5 context could be created (EGL or Mesa missing)."""


class GLError(RuntimeError):
    """OpenGL reported an error."""


def check_choice(name: str, value, choices: Sequence) -> None:
    """Raise ``ValueError("<name> must be one of <choices>, got <value>")`` unless ``value`` is
    one of ``choices`` (an option given as a string or number from a fixed set)."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {tuple(choices)}, got {value!r}")
