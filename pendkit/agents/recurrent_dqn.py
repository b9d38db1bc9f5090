"""R-DQN with a trained GRU encoder.

What the paper states ("R-DQN and R-TD3"): a GRU encodes the observation sequence from the start of the
episode, one GRU step per env step; its vector, joined to the current observation, is the Q-network's
input. What it leaves open, and what we chose:
- The GRU is trained by the TD loss, end to end with the Q-head. The replay buffer therefore keeps raw
  inputs, not encodings, and re-encodes stretches of episodes when they are sampled, starting from the
  recurrent state the actor had (stored with each step) and warming it up over a burn-in before the loss
  (Kapturowski et al. 2019, "stored state" with "burn-in"). A fixed, untrained GRU was our first version;
  it saturates on raw inputs and adds little a probe can read (docs/rl.md), so it survives only as the
  `r-dqn-reservoir` ablation.
- Inputs (observation and recent actions) are normalised with running statistics before the GRU and the
  head; the statistics travel with the weights in checkpoints.
- The target network is a copy of GRU and head; double-DQN targets; Huber loss, as in our plain DQN.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pendkit.agents.base import EpsilonGreedyConfig, SequenceConfig
from pendkit.agents.dqn import linear_epsilon, q_learning_step
from pendkit.agents.nets import adam, masked_mean, mlp
from pendkit.agents.recurrent import GruTrunk, RecurrentAgent, device_network
from pendkit.agents.sequence_replay import SequenceBatch
from pendkit.device.blob_parts import NetworkBlob


@dataclass(frozen=True)
class RecurrentDqnConfig(SequenceConfig, EpsilonGreedyConfig):
    """R-DQN settings: the DQN ones plus the GRU's size and the replayed stretch (burn-in + trained steps)."""

    # 64 stretches x 8 steps every 8 env steps: 64 replayed steps per env step, as DQN's batch. Fewer, larger
    # updates cost a third of the time of 32 x 8 every 4 on a CPU and solved `realistic` sooner (docs/rl.md).
    update_every: int = 8
    epsilon_decay_steps: int = 10_000


class RecurrentQ(nn.Module):
    """Q-values from [normalised input, GRU state]."""

    def __init__(self, input_dim: int, n_actions: int, gru_size: int, hidden: tuple[int, ...]) -> None:
        super().__init__()
        self.trunk = GruTrunk(input_dim, gru_size)
        self.head = mlp(input_dim + gru_size, n_actions, hidden)

    def q(self, inputs: torch.Tensor, hiddens: torch.Tensor) -> torch.Tensor:
        return self.head(torch.cat([inputs, hiddens], dim=-1))


class RecurrentDqnAgent(RecurrentAgent):
    """`reset()` at each episode start; `act(x)` advances the GRU; `update(SequenceBatch)`; `state_dict()`;
    `device_network()`: the greedy network as the device runs it."""

    NETWORK, OPTIMIZERS = "q", ("optimizer",)

    def __init__(self, input_dim: int, n_actions: int, config: RecurrentDqnConfig | None = None) -> None:
        self.config = c = config or RecurrentDqnConfig()
        torch.manual_seed(c.seed)
        self.n_actions = n_actions
        self._start(input_dim, RecurrentQ(input_dim, n_actions, c.gru_size, c.hidden))
        self.optimizer = adam(self.q.parameters(), c.learning_rate)

    @property
    def epsilon(self) -> float:
        c = self.config
        return linear_epsilon(self.steps, c.epsilon_start, c.epsilon_end, c.epsilon_decay_steps)

    def q_values(self, x) -> np.ndarray:
        """The GRU one step further on raw input `x`: the Q-values of the actions, (n_actions,)."""
        with torch.no_grad():
            z = self._advance(x)
            return self.q.q(z, self.hidden)[0].numpy()

    def act(self, x, explore: bool = True) -> int:
        values = self.q_values(x)
        if explore:
            self.steps += 1
            if self.rng.random() < self.epsilon:
                return int(self.rng.integers(self.n_actions))
        return int(values.argmax())

    def update(self, batch: SequenceBatch) -> dict[str, float]:
        """One gradient step on the TD error over re-encoded stretches; the burn-in carries no gradient."""
        c, b = self.config, self.config.burn_in
        x_t, x_next, online_h, target_h = self._replayed(batch)
        q_taken = self.q.q(x_t, online_h).gather(-1, batch.actions[:, b:].unsqueeze(-1)).squeeze(-1)
        with torch.no_grad():
            online_next = self.q.q(x_next, self.q.trunk.step_all(x_next, online_h))
            best = online_next.argmax(dim=-1, keepdim=True)
            next_value = self.target.q(x_next, self.target.trunk.step_all(x_next, target_h)).gather(-1, best)
            target = batch.rewards[:, b:] + c.gamma * (1.0 - batch.dones[:, b:]) * next_value.squeeze(-1)
        mask = batch.loss_mask[:, b:]
        loss = masked_mean(nn.functional.huber_loss(q_taken, target, delta=c.huber_delta, reduction="none"), mask)
        value = q_learning_step(self, loss, "R-DQN")
        return {"loss": value, "q_mean": float(masked_mean(q_taken.detach(), mask)), "epsilon": self.epsilon}

    def device_network(self) -> NetworkBlob:
        """The greedy network as the device runs it: the GRU, then the Q-head, the action the largest value's."""
        return device_network(self.q.trunk, list(self.q.head), self.normalizer, "argmax")
