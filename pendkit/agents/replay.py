"""A uniform replay buffer over fixed-size numpy arrays; batches come out as torch tensors."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch

from pendkit.errors import ConfigError


class Batch(NamedTuple):
    observations: torch.Tensor
    actions: torch.Tensor
    rewards: torch.Tensor
    next_observations: torch.Tensor
    dones: torch.Tensor


class ReplayBuffer:
    """The newest `capacity` transitions; `sample` draws uniformly with its own seeded generator."""

    def __init__(self, capacity: int, observation_dim: int, seed: int = 0, action_dim: int | None = None) -> None:
        """`action_dim=None`: discrete actions (one int each); otherwise continuous actions of that size."""
        if capacity < 1 or observation_dim < 1:
            raise ConfigError(f"capacity and observation_dim must be >= 1, got {capacity}, {observation_dim}")
        self.capacity = capacity
        self.observations = np.zeros((capacity, observation_dim), dtype=np.float32)
        self.next_observations = np.zeros((capacity, observation_dim), dtype=np.float32)
        self.actions = (np.zeros(capacity, dtype=np.int64) if action_dim is None
                        else np.zeros((capacity, action_dim), dtype=np.float32))
        self.rewards = np.zeros(capacity, dtype=np.float32)
        self.dones = np.zeros(capacity, dtype=np.float32)
        self.size = self.position = 0
        self.added = 0  # every transition ever stored, also those the newest have since pushed out
        self.rng = np.random.default_rng(seed)

    def __len__(self) -> int:
        return self.size

    def add(self, observation, action: int, reward: float, next_observation, done: bool, *, episode: int = 0,
            step: int = 0) -> None:
        """One transition (`episode` and `step` are the trainers' keys; a uniform buffer has no use for them)."""
        k = self.position
        self.observations[k], self.next_observations[k] = observation, next_observation
        self.actions[k], self.rewards[k], self.dones[k] = action, reward, float(done)
        self.position = (k + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)
        self.added += 1

    def sample(self, batch_size: int) -> Batch:
        if self.size == 0:
            raise ConfigError("cannot sample from an empty replay buffer")
        index = self.rng.integers(0, self.size, batch_size)
        return Batch(torch.from_numpy(self.observations[index]), torch.from_numpy(self.actions[index]),
                     torch.from_numpy(self.rewards[index]), torch.from_numpy(self.next_observations[index]),
                     torch.from_numpy(self.dones[index]))

    def state_dict(self) -> dict:
        return {"arrays": {name: getattr(self, name).copy() for name in
                           ("observations", "next_observations", "actions", "rewards", "dones")},
                "size": self.size, "position": self.position, "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict) -> None:
        for name, array in state["arrays"].items():
            getattr(self, name)[...] = array
        self.size, self.position = state["size"], state["position"]
        self.rng.bit_generator.state = state["rng"]
