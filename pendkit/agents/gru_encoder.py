"""The `r-dqn-reservoir` ablation: a fixed, untrained random GRU (an echo-state reservoir) unrolled one step
per env step; its hidden vector joined to the current input is what a plain DQN or TD3 sees.

This was the kit's first R-DQN encoder, chosen because a fixed encoder keeps stored encodings valid. It
teaches why the paper's GRU has to be trained: on raw rig inputs about half of its units saturate (|h| >
0.95) and two thirds of its update gates are pinned, and a linear probe reads the present pendulum rate
from a 2-step-late input only a little better with its encoding than without (R^2 0.51-0.61 against
0.46-0.58; `benchmarks/bench_encoders.py`, docs/rl.md). The trained encoder is `pendkit.agents.recurrent_dqn`.
Tests check that the weights never change and that different histories give different vectors.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from pendkit.agents.threads import use_kit_threads


class GruEncoder:
    """Encodes the episode so far; call `reset()` at each episode start, `encode(x)` once per step."""

    def __init__(self, input_dim: int, hidden_size: int = 32, seed: int = 0) -> None:
        use_kit_threads()
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
