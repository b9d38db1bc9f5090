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


class RecordingError(PendkitError, ValueError):
    """A rig's recording failed a check before identification (a stuck or jumping encoder, a device clock gone
    back, readings lost, a servo range the status misreports); the message names the sensor or the clock."""


class IdentificationError(PendkitError):
    """An identification too poor to deploy from (its matching cost not finite, or hardly better than a
    pendulum that never moved); the message says which."""
