"""The R-DQN encoder (paper, "R-DQN and R-TD3"): a GRU unrolled one step per env step from the start of
the episode; its hidden vector joined to the current observation is what the agent sees and what the
replay buffer stores.

How it is trained, which the paper leaves open: not at all, by design. The replay buffer stores encoded
vectors, as the paper says; a vector stays a valid input only if the encoder that made it has not changed
since, so a trained encoder would make every stored transition stale. A fixed random GRU (an echo-state
reservoir) keeps every stored vector consistent, while its hidden state still carries the history a
delayed rig hides: past angles, velocities and actions. The tests check both properties: the parameters
never change, and different histories give different vectors.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn


class GruEncoder:
    """Encodes the episode so far; call `reset()` at each episode start, `encode(x)` once per step."""

    def __init__(self, input_dim: int, hidden_size: int = 32, seed: int = 0) -> None:
        generator = torch.Generator().manual_seed(seed)
        self.cell = nn.GRUCell(input_dim, hidden_size)
        with torch.no_grad():
            for parameter in self.cell.parameters():
                parameter.copy_(torch.empty_like(parameter).uniform_(-0.5, 0.5, generator=generator))
        self.cell.requires_grad_(False)  # fixed: see the module's docstring
        self.input_dim, self.hidden_size = input_dim, hidden_size
        self.reset()

    @property
    def output_dim(self) -> int:
        return self.input_dim + self.hidden_size

    def reset(self) -> None:
        self.hidden = torch.zeros(1, self.hidden_size)

    def encode(self, step_input) -> np.ndarray:
        """Advance one step with this step's input (observation and last action); return [input, hidden]."""
        x = torch.as_tensor(np.asarray(step_input, dtype=np.float32)).reshape(1, -1)
        with torch.no_grad():
            self.hidden = self.cell(x, self.hidden)
        return np.concatenate([x.numpy()[0], self.hidden.numpy()[0]]).astype(np.float32)
