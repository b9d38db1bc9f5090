"""R-TD3 with a trained GRU encoder: TD3 whose actor and critics see [input, GRU state].

What the paper states: as R-DQN, a GRU encodes the episode so far, one step per env step, and its vector
joined to the current observation is the networks' input. What we chose: one GRU, trained by the critics'
TD loss over re-encoded replay stretches (stored state plus burn-in, as in our R-DQN); the actor reads the
GRU's state without sending gradient into it, so the encoder learns what predicts value and the actor
does not pull it towards whatever flatters the critic. Inputs are normalised with running statistics.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pendkit.agents.base import ActorCriticConfig, SequenceConfig
from pendkit.agents.nets import adam, descend, masked_mean, mlp, soft_update
from pendkit.agents.normalizer import RunningNormalizer
from pendkit.agents.recurrent import GruTrunk
from pendkit.agents.sequence_replay import SequenceBatch, SequenceReplay


@dataclass(frozen=True)
class RecurrentTd3Config(SequenceConfig, ActorCriticConfig):
    batch_size: int = 32
    buffer_capacity: int = 100_000
    learning_starts: int = 1000
    update_every: int = 2


class RecurrentActorCritic(nn.Module):
    def __init__(self, input_dim: int, action_dim: int, gru_size: int, hidden: tuple[int, ...]) -> None:
        super().__init__()
        self.trunk = GruTrunk(input_dim, gru_size)
        width = input_dim + gru_size
        self.actor = nn.Sequential(mlp(width, action_dim, hidden), nn.Tanh())
        self.critics = nn.ModuleList([mlp(width + action_dim, 1, hidden) for _ in range(2)])

    def q(self, features: torch.Tensor, actions: torch.Tensor, critics=None) -> list[torch.Tensor]:
        joined = torch.cat([features, actions], dim=-1)
        return [critic(joined).squeeze(-1) for critic in (critics or self.critics)]


class RecurrentTd3Agent:
    """`reset()` per episode; `act(x)` advances the GRU; `update(SequenceBatch)`; `state_dict()`."""

    def __init__(self, input_dim: int, action_dim: int, config: RecurrentTd3Config | None = None) -> None:
        self.config = c = config or RecurrentTd3Config()
        torch.manual_seed(c.seed)
        self.input_dim, self.action_dim = input_dim, action_dim
        self.net = RecurrentActorCritic(input_dim, action_dim, c.gru_size, c.hidden)
        self.target = copy.deepcopy(self.net)
        self.actor_optimizer = adam(self.net.actor.parameters(), c.actor_learning_rate)
        self.critic_optimizer = adam([*self.net.trunk.parameters(), *self.net.critics.parameters()],
                                     c.critic_learning_rate)
        self.normalizer = RunningNormalizer(input_dim)
        self.rng = np.random.default_rng(c.seed)
        self.steps = self.updates = 0
        self.reset()

    def new_buffer(self, seed: int = 0) -> SequenceReplay:
        c = self.config
        return SequenceReplay(c.buffer_capacity, self.input_dim, c.gru_size, c.burn_in, c.sequence_length, seed,
                              action_dim=self.action_dim)

    def reset(self) -> None:
        self.hidden = torch.zeros(1, self.config.gru_size)
        self.hidden_before = self.hidden[0].numpy().copy()

    def step_extras(self) -> dict:
        return {"hidden": self.hidden_before}

    def track_input(self, x) -> None:
        self.normalizer.update(x)

    def act(self, x, explore: bool = True) -> np.ndarray:
        self.hidden_before = self.hidden[0].numpy().copy()
        with torch.no_grad():
            z = self.normalizer.normalize(torch.as_tensor(np.asarray(x, dtype=np.float32)).reshape(1, -1))
            self.hidden = self.net.trunk.step(z, self.hidden)
            action = self.net.actor(torch.cat([z, self.hidden], dim=-1))[0].numpy()
        if explore:
            self.steps += 1
            action = action + self.rng.normal(0.0, self.config.exploration_noise, self.action_dim)
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    def update(self, batch: SequenceBatch) -> dict[str, float]:
        c, b = self.config, self.config.burn_in
        inputs, next_inputs = self.normalizer.normalize(batch.inputs), self.normalizer.normalize(batch.next_inputs)
        start_h = self.net.trunk.warm_start(inputs, batch.hidden, batch.starts, b)
        online_h = self.net.trunk.unroll(inputs[:, b:], torch.cat([start_h[:, None], batch.hidden[:, b + 1:]], 1),
                                         batch.starts[:, b:])
        x_t, x_next, mask = inputs[:, b:], next_inputs[:, b:], batch.loss_mask[:, b:]
        actions = batch.actions[:, b:].reshape(*x_t.shape[:2], -1).float()
        with torch.no_grad():
            target_h = self.target.trunk.unroll(inputs, batch.hidden, batch.starts)[:, b:]
            next_features = torch.cat([x_next, self.target.trunk.step_all(x_next, target_h)], dim=-1)
            noise = (torch.randn_like(actions) * c.target_noise).clamp(-c.target_noise_clip, c.target_noise_clip)
            next_actions = (self.target.actor(next_features) + noise).clamp(-1.0, 1.0)
            next_q = torch.min(*self.target.q(next_features, next_actions))
            target = batch.rewards[:, b:] + c.gamma * (1.0 - batch.dones[:, b:]) * next_q
        features = torch.cat([x_t, online_h], dim=-1)
        q1, q2 = self.net.q(features, actions)
        critic_loss = masked_mean((q1 - target) ** 2 + (q2 - target) ** 2, mask)
        descend(self.critic_optimizer, critic_loss, [], max_grad_norm=None)
        self.updates += 1
        metrics = {"critic_loss": float(critic_loss.item())}
        if self.updates % c.policy_delay == 0:
            detached = features.detach()
            actor_loss = -masked_mean(self.net.q(detached, self.net.actor(detached), self.net.critics[:1])[0], mask)
            descend(self.actor_optimizer, actor_loss, [], max_grad_norm=None)
            soft_update(self.net, self.target, c.tau)
            metrics["actor_loss"] = float(actor_loss.item())
        if not math.isfinite(metrics["critic_loss"]):
            raise FloatingPointError("the R-TD3 critic loss is not finite: lower the learning rates")
        return metrics

    def policy_state(self) -> dict:
        return {"net": {k: v.clone() for k, v in self.net.state_dict().items()},
                "normalizer": self.normalizer.state_dict()}

    def load_policy(self, state: dict) -> None:
        self.net.load_state_dict(state["net"])
        self.normalizer.load_state_dict(state["normalizer"])

    def state_dict(self) -> dict:
        return {"net": self.net.state_dict(), "target": self.target.state_dict(),
                "actor_optimizer": self.actor_optimizer.state_dict(),
                "critic_optimizer": self.critic_optimizer.state_dict(), "normalizer": self.normalizer.state_dict(),
                "steps": self.steps, "updates": self.updates, "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict) -> None:
        for name in ("net", "target", "actor_optimizer", "critic_optimizer", "normalizer"):
            getattr(self, name).load_state_dict(state[name])
        self.steps, self.updates = state["steps"], state["updates"]
        self.rng.bit_generator.state = state["rng"]
