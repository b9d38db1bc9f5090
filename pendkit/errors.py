"""The kit's exceptions: one hierarchy, so callers can catch `PendkitError`.

Input errors subclass `ValueError` as well, so code written against plain Python conventions still works.
"""


class PendkitError(Exception):
    """Base class of every error pendkit raises on purpose."""


class ConfigError(PendkitError, ValueError):
    """A parameter or setting is outside its allowed range."""


class ActionError(PendkitError, ValueError):
    """An action does not fit the env's action space (shape, dtype, range, NaN)."""


class FrameError(PendkitError, ValueError):
    """An encoder SSI frame failed a check (parity, status bits, width)."""


class MissingExtraError(PendkitError, ImportError):
    """An optional dependency is missing; the message names the install command."""
