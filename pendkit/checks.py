"""Checks on numbers every layer makes: a finite real (not a bool), and a dataclass's numeric fields in range."""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable

from pendkit.errors import ConfigError


def is_finite_number(value) -> bool:
    """A real number that is neither a bool nor NaN/inf (numpy scalars count)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def check_fields(settings, allowed: Callable[[float], bool], wanted: str, skip: tuple[str, ...] = ()) -> None:
    """ConfigError naming the first field of the dataclass `settings` that is not a finite number `allowed`
    accepts (`wanted` says what it must be, e.g. "> 0"); the fields in `skip` are the caller's to check."""
    for name, value in vars(settings).items():
        if name not in skip and not (is_finite_number(value) and allowed(value)):
            raise ConfigError(f"{type(settings).__name__}.{name} must be finite and {wanted}, got {value!r}")
