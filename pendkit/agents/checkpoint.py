"""Checkpoints: weights, optimiser, replay buffer, RNG states and progress, written atomically, so a run
killed at any moment (kill -9) resumes from the last checkpoint with nothing else lost."""

from __future__ import annotations

import random
from pathlib import Path

import numpy as np
import torch

from pendkit.agents.data_files import load_data, save_data


def save_checkpoint(path: str | Path, agent, buffer, episode: int, returns: list[float], extra: dict) -> None:
    state = {"agent": agent.state_dict(), "buffer": buffer.state_dict(), "episode": episode, "returns": returns,
             "torch_rng": torch.get_rng_state(), "numpy_rng": np.random.get_state(), "python_rng": random.getstate(),
             "extra": extra}
    save_data(path, state)  # atomic: a kill leaves the old checkpoint or the new one, never half of one


def load_checkpoint(path: str | Path, agent, buffer) -> tuple[int, list[float], dict]:
    """Restore `agent` and `buffer` in place; return (next episode, returns so far, extra)."""
    state = load_data(path, "training checkpoint")
    agent.load_state_dict(state["agent"])
    buffer.load_state_dict(state["buffer"])
    torch.set_rng_state(state["torch_rng"])
    np.random.set_state(state["numpy_rng"])
    random.setstate(_tuples(state["python_rng"]))
    return state["episode"], list(state["returns"]), state["extra"]


def _tuples(value):
    """random.setstate wants tuples all the way down."""
    return tuple(_tuples(item) for item in value) if isinstance(value, (list, tuple)) else value
