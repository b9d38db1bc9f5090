"""Weights and checkpoints as data: torch's `weights_only` loader reads them, so a crafted file cannot run
code on the machine that loads it (a student's run folder, a download).

numpy arrays travel as tensors (every numpy dtype the kit stores has a torch twin) and numpy scalars as
Python numbers; `load_data` gives them back as numpy. A file that is not one of these, truncated, empty or
from an older pendkit that pickled numpy objects, is refused in one line that names it.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import numpy as np
import torch

from pendkit.errors import ConfigError
from pendkit.safe_write import replacing

_ARRAY = "__ndarray__"


def to_data(value: Any) -> Any:
    """`value` with numpy arrays as tagged tensors and numpy scalars as Python numbers."""
    if isinstance(value, np.ndarray):
        return {_ARRAY: torch.from_numpy(np.ascontiguousarray(value).copy())}
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, dict):
        return {key: to_data(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(to_data(item) for item in value)
    return value


def from_data(value: Any) -> Any:
    """`to_data`'s inverse."""
    if isinstance(value, dict):
        if set(value) == {_ARRAY} and isinstance(value[_ARRAY], torch.Tensor):
            return value[_ARRAY].numpy()
        return {key: from_data(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(from_data(item) for item in value)
    return value


def save_data(path: str | Path, value: Any) -> Path:
    """Write `value` atomically (a kill leaves the old file or the new one, never half of one), never through
    a link planted at `path` (`pendkit.safe_write`)."""

    path = Path(path)
    with replacing(path, binary=True) as handle:
        torch.save(to_data(value), handle)
    return path


def load_data(path: str | Path, what: str = "weights file") -> Any:
    """Read a file `save_data` wrote, as data only; a ConfigError naming `path` for anything else."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"no {what} at {path}")
    try:
        return from_data(torch.load(path, weights_only=True, map_location="cpu"))
    except pickle.UnpicklingError as error:
        lines = [line.strip() for line in str(error).splitlines() if line.strip()]
        crafted = next((line for line in lines if "Unsupported global" in line), None)
        if crafted is None:
            raise ConfigError(f"{path} is not a readable {what}: truncated, empty or not the kit's") from None
        raise ConfigError(f"{path} is not a {what} the kit reads as data (it asks to run "
                          f"{crafted.split('GLOBAL', 1)[-1].split()[0]}): train it again, or, if it came from an "
                          "older pendkit and you trust it, re-save it with that version") from None
    except (RuntimeError, EOFError, ValueError, OSError, AttributeError, TypeError, KeyError,
            IndexError, MemoryError) as error:
        reason = (str(error).splitlines() or [type(error).__name__])[0][:160]
        raise ConfigError(f"{path} is not a readable {what}: truncated, empty or not the kit's ({reason})") from None
