"""Replay of whole stretches of episodes for recurrent agents (recurrent replay DQN, Kapturowski et al.
2019): every step keeps its raw input, action, reward, next input and the recurrent state the actor had
before the step, so a sampled stretch can be re-encoded by the *current* encoder.

A stretch is `burn_in + length` consecutive steps of one episode. The burn-in steps only warm up the
stored (stale) recurrent state; the loss covers the last `length` steps. Steps from several actors may
interleave in the buffer: a step belongs to a stretch only if its episode key matches and its step index
follows on, so interleaving costs masked steps, never wrong ones.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import torch

from pendkit.errors import ConfigError


class SequenceBatch(NamedTuple):
    """Tensors of shape (batch, steps, ...); `starts` marks where the stored recurrent state must be taken
    (a stretch's first step, or a step whose predecessor is not its predecessor in the episode)."""

    inputs: torch.Tensor
    actions: torch.Tensor
    rewards: torch.Tensor
    next_inputs: torch.Tensor
    dones: torch.Tensor
    hidden: torch.Tensor
    starts: torch.Tensor
    loss_mask: torch.Tensor


class SequenceReplay:
    """The newest `capacity` steps; `sample(batch_size)` draws stretches ending at uniformly drawn steps."""

    def __init__(self, capacity: int, input_dim: int, hidden_dim: int, burn_in: int, length: int, seed: int = 0,
                 action_dim: int | None = None) -> None:
        if capacity < 1 or input_dim < 1 or hidden_dim < 1 or burn_in < 0 or length < 1:
            raise ConfigError(f"need capacity, input_dim, hidden_dim, length >= 1 and burn_in >= 0, got "
                              f"{capacity}, {input_dim}, {hidden_dim}, {length}, {burn_in}")
        self.capacity, self.burn_in, self.length = capacity, burn_in, length
        self.inputs = np.zeros((capacity, input_dim), np.float32)
        self.next_inputs = np.zeros((capacity, input_dim), np.float32)
        self.actions = (np.zeros(capacity, np.int64) if action_dim is None
                        else np.zeros((capacity, action_dim), np.float32))
        self.rewards = np.zeros(capacity, np.float32)
        self.dones = np.zeros(capacity, np.float32)
        self.hidden = np.zeros((capacity, hidden_dim), np.float32)
        self.episode = np.full(capacity, -1, np.int64)
        self.step = np.zeros(capacity, np.int64)
        self.size = self.position = 0
        self.rng = np.random.default_rng(seed)

    def __len__(self) -> int:
        return self.size

    def add(self, x, action, reward: float, x_next, done: bool, *, hidden, episode: int, step: int) -> None:
        """One step: `hidden` is the recurrent state before `x`; `episode` a key unique per actor episode."""
        k = self.position
        self.inputs[k], self.next_inputs[k], self.hidden[k] = x, x_next, hidden
        self.actions[k], self.rewards[k], self.dones[k] = action, reward, float(done)
        self.episode[k], self.step[k] = episode, step
        self.position = (k + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)

    def sample(self, batch_size: int) -> SequenceBatch:
        if self.size == 0:
            raise ConfigError("cannot sample from an empty replay buffer")
        span = self.burn_in + self.length
        # The newest step is at position - 1; draw the stretch's last step among the stored ones, then
        # index backwards (in insertion order, so a wrapped buffer reads oldest to newest correctly).
        age = self.rng.integers(0, self.size, batch_size)  # 0 = newest
        last = (self.position - 1 - age) % self.capacity
        offsets = np.arange(-(span - 1), 1)
        rows = (last[:, None] + offsets[None, :]) % self.capacity
        in_store = (age[:, None] - offsets[None, :]) < self.size  # not older than the oldest stored step
        episode, step = self.episode[rows], self.step[rows]
        follows_last = in_store & (episode == episode[:, -1:]) & (step == step[:, -1:] + offsets[None, :])
        starts = np.zeros_like(follows_last)
        starts[:, 0] = True
        starts[:, 1:] = ~follows_last[:, :-1] & follows_last[:, 1:]  # first step that belongs to the stretch
        loss_mask = follows_last.copy()
        loss_mask[:, :self.burn_in] = False
        return SequenceBatch(
            torch.from_numpy(self.inputs[rows]), torch.from_numpy(self.actions[rows]),
            torch.from_numpy(self.rewards[rows]), torch.from_numpy(self.next_inputs[rows]),
            torch.from_numpy(self.dones[rows]), torch.from_numpy(self.hidden[rows]),
            torch.from_numpy(starts), torch.from_numpy(loss_mask.astype(np.float32)))

    _ARRAYS = ("inputs", "next_inputs", "actions", "rewards", "dones", "hidden", "episode", "step")

    def state_dict(self) -> dict:
        return {"arrays": {name: getattr(self, name).copy() for name in self._ARRAYS}, "size": self.size,
                "position": self.position, "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict) -> None:
        for name, array in state["arrays"].items():
            getattr(self, name)[...] = array
        self.size, self.position = state["size"], state["position"]
        self.rng.bit_generator.state = state["rng"]
