"""Run modes of the labs: PENDKIT_MODE=interactive|ci|grade, and strict grading."""

from __future__ import annotations

import os
from typing import TypeVar

from pendkit.errors import ConfigError

MODES = ("interactive", "ci", "grade")
T = TypeVar("T")


def mode() -> str:
    """The current mode: interactive (default), ci (shrunk budgets) or grade (run by `pendkit grade`)."""
    value = os.environ.get("PENDKIT_MODE", "interactive").strip().lower() or "interactive"
    if value not in MODES:
        raise ConfigError(f"PENDKIT_MODE must be one of {MODES}, got {value!r}")
    return value


def strict() -> bool:
    """PENDKIT_GRADER_STRICT=1: `check` raises on anything short of full marks (used on solutions/)."""
    return os.environ.get("PENDKIT_GRADER_STRICT", "0").strip().lower() in ("1", "true", "yes")


def budget(interactive: T, ci: T, grade: T | None = None) -> T:
    """Pick a horizon or training budget for the current mode: `steps = budget(500, 100)`.

    grade defaults to the ci value: graders run many notebooks.
    """
    current = mode()
    if current == "interactive":
        return interactive
    if current == "grade" and grade is not None:
        return grade
    return ci
