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

import copy
import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pendkit.agents.base import EpsilonGreedyConfig, SequenceConfig
from pendkit.agents.dqn import linear_epsilon
from pendkit.agents.nets import adam, descend, masked_mean, mlp
from pendkit.agents.normalizer import RunningNormalizer
from pendkit.agents.recurrent import GruTrunk
from pendkit.agents.sequence_replay import SequenceBatch, SequenceReplay


@dataclass(frozen=True)
class RecurrentDqnConfig(SequenceConfig, EpsilonGreedyConfig):
    """R-DQN settings: the DQN ones plus the GRU's size and the replayed stretch (burn-in + trained steps)."""

    buffer_capacity: int = 100_000
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


class RecurrentDqnAgent:
    """`reset()` at each episode start; `act(x)` advances the GRU; `update(SequenceBatch)`; `state_dict()`.
    `step_extras()` hands the trainer the state before the last `act`, stored with the step."""

    def __init__(self, input_dim: int, n_actions: int, config: RecurrentDqnConfig | None = None) -> None:
        self.config = c = config or RecurrentDqnConfig()
        torch.manual_seed(c.seed)
        self.n_actions, self.input_dim = n_actions, input_dim
        self.q = RecurrentQ(input_dim, n_actions, c.gru_size, c.hidden)
        self.target = copy.deepcopy(self.q)
        self.optimizer = adam(self.q.parameters(), c.learning_rate)
        self.normalizer = RunningNormalizer(input_dim)
        self.rng = np.random.default_rng(c.seed)
        self.steps = self.updates = 0
        self.reset()

    @property
    def hidden_dim(self) -> int:
        return self.config.gru_size

    def new_buffer(self, seed: int = 0) -> SequenceReplay:
        c = self.config
        return SequenceReplay(c.buffer_capacity, self.input_dim, c.gru_size, c.burn_in, c.sequence_length, seed)

    @property
    def epsilon(self) -> float:
        c = self.config
        return linear_epsilon(self.steps, c.epsilon_start, c.epsilon_end, c.epsilon_decay_steps)

    def reset(self) -> None:
        self.hidden = torch.zeros(1, self.config.gru_size)
        self.hidden_before = self.hidden[0].numpy().copy()

    def step_extras(self) -> dict:
        return {"hidden": self.hidden_before}

    def track_input(self, x) -> None:
        """Fold a new raw input into the normalisation statistics (the trainer calls this once per step)."""
        self.normalizer.update(x)

    def act(self, x, explore: bool = True) -> int:
        self.hidden_before = self.hidden[0].numpy().copy()
        with torch.no_grad():
            z = self.normalizer.normalize(torch.as_tensor(np.asarray(x, dtype=np.float32)).reshape(1, -1))
            self.hidden = self.q.trunk.step(z, self.hidden)
            values = self.q.q(z, self.hidden)
        if explore:
            self.steps += 1
            if self.rng.random() < self.epsilon:
                return int(self.rng.integers(self.n_actions))
        return int(values.argmax(dim=1).item())

    def update(self, batch: SequenceBatch) -> dict[str, float]:
        """One gradient step on the TD error over re-encoded stretches; the burn-in carries no gradient."""
        c = self.config
        norm = self.normalizer.normalize
        inputs, next_inputs = norm(batch.inputs), norm(batch.next_inputs)
        b = c.burn_in
        start_h = self.q.trunk.warm_start(inputs, batch.hidden, batch.starts, b)
        online_h = self.q.trunk.unroll(inputs[:, b:], torch.cat([start_h[:, None], batch.hidden[:, b + 1:]], 1),
                                       batch.starts[:, b:])
        x_t, x_next = inputs[:, b:], next_inputs[:, b:]
        q_taken = self.q.q(x_t, online_h).gather(-1, batch.actions[:, b:].unsqueeze(-1)).squeeze(-1)
        with torch.no_grad():
            target_h = self.target.trunk.unroll(inputs, batch.hidden, batch.starts)[:, b:]
            online_next = self.q.q(x_next, self.q.trunk.step_all(x_next, online_h))
            best = online_next.argmax(dim=-1, keepdim=True)
            next_value = self.target.q(x_next, self.target.trunk.step_all(x_next, target_h)).gather(-1, best)
            target = batch.rewards[:, b:] + c.gamma * (1.0 - batch.dones[:, b:]) * next_value.squeeze(-1)
        mask = batch.loss_mask[:, b:]
        loss = masked_mean(nn.functional.huber_loss(q_taken, target, delta=c.huber_delta, reduction="none"), mask)
        descend(self.optimizer, loss, self.q.parameters())
        self.updates += 1
        if self.updates % c.target_update_every == 0:
            self.target.load_state_dict(self.q.state_dict())
        value = float(loss.item())
        if not math.isfinite(value):
            raise FloatingPointError("the R-DQN loss is not finite: lower the learning rate")
        return {"loss": value, "q_mean": float(masked_mean(q_taken.detach(), mask)),
                "epsilon": self.epsilon}

    def policy_state(self) -> dict:
        """What an actor needs to act: the network's weights and the input statistics (copied)."""
        return {"q": {k: v.clone() for k, v in self.q.state_dict().items()},
                "normalizer": self.normalizer.state_dict()}

    def load_policy(self, state: dict) -> None:
        self.q.load_state_dict(state["q"])
        self.normalizer.load_state_dict(state["normalizer"])

    def state_dict(self) -> dict:
        return {"q": self.q.state_dict(), "target": self.target.state_dict(),
                "optimizer": self.optimizer.state_dict(), "normalizer": self.normalizer.state_dict(),
                "steps": self.steps, "updates": self.updates, "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict) -> None:
        self.q.load_state_dict(state["q"])
        self.target.load_state_dict(state["target"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.normalizer.load_state_dict(state["normalizer"])
        self.steps, self.updates = state["steps"], state["updates"]
        self.rng.bit_generator.state = state["rng"]
