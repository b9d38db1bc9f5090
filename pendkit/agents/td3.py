"""TD3 (Fujimoto et al. 2018): a deterministic actor, twin critics with the smaller target, target-policy
smoothing, delayed actor updates and soft target updates. Actions lie in [-1, 1] (the env's continuous
servo target)."""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pendkit.agents.base import ActorCriticConfig, FeedForwardActor
from pendkit.agents.nets import adam, descend, mlp, soft_update
from pendkit.agents.replay import Batch, ReplayBuffer


@dataclass(frozen=True)
class Td3Config(ActorCriticConfig):
    batch_size: int = 128
    buffer_capacity: int = 100_000
    learning_starts: int = 1000


class Td3Agent(FeedForwardActor):
    """`act(observation, explore)` -> action array in [-1, 1]; `update(batch)`; `state_dict()`."""

    MODULES = ("actor", "critics", "actor_target", "critics_target", "actor_optimizer", "critic_optimizer")

    def __init__(self, observation_dim: int, action_dim: int, config: Td3Config | None = None) -> None:
        self.config = config or Td3Config()
        torch.manual_seed(self.config.seed)
        self.input_dim, self.action_dim = observation_dim, action_dim
        self.actor = nn.Sequential(mlp(observation_dim, action_dim, self.config.hidden), nn.Tanh())
        self.critics = nn.ModuleList([mlp(observation_dim + action_dim, 1, self.config.hidden) for _ in range(2)])
        self.actor_target, self.critics_target = copy.deepcopy(self.actor), copy.deepcopy(self.critics)
        self.actor_optimizer = adam(self.actor.parameters(), self.config.actor_learning_rate)
        self.critic_optimizer = adam(self.critics.parameters(), self.config.critic_learning_rate)
        self.rng = np.random.default_rng(self.config.seed)
        self.steps = self.updates = 0

    def new_buffer(self, seed: int = 0) -> ReplayBuffer:
        return ReplayBuffer(self.config.buffer_capacity, self.input_dim, seed, action_dim=self.action_dim)

    def act(self, observation, explore: bool = True) -> np.ndarray:
        with torch.no_grad():
            action = self.actor(torch.as_tensor(np.asarray(observation, dtype=np.float32)).unsqueeze(0))[0].numpy()
        if explore:
            self.steps += 1
            action = action + self.rng.normal(0.0, self.config.exploration_noise, self.action_dim)
        return np.clip(action, -1.0, 1.0).astype(np.float32)

    def _q(self, critics, observations, actions) -> list[torch.Tensor]:
        joined = torch.cat([observations, actions], dim=1)
        return [critic(joined).squeeze(1) for critic in critics]

    def update(self, batch: Batch) -> dict[str, float]:
        c = self.config
        actions = batch.actions.reshape(len(batch.actions), -1).float()
        with torch.no_grad():
            noise = (torch.randn_like(actions) * c.target_noise).clamp(-c.target_noise_clip, c.target_noise_clip)
            next_actions = (self.actor_target(batch.next_observations) + noise).clamp(-1.0, 1.0)
            next_q = torch.min(*self._q(self.critics_target, batch.next_observations, next_actions))
            target = batch.rewards + c.gamma * (1.0 - batch.dones) * next_q
        q1, q2 = self._q(self.critics, batch.observations, actions)
        critic_loss = nn.functional.mse_loss(q1, target) + nn.functional.mse_loss(q2, target)
        descend(self.critic_optimizer, critic_loss, self.critics.parameters(), max_grad_norm=None)
        self.updates += 1
        metrics = {"critic_loss": float(critic_loss.item())}
        if self.updates % c.policy_delay == 0:  # the actor (and the targets) move half as often
            actor_loss = -self._q(self.critics[:1], batch.observations, self.actor(batch.observations))[0].mean()
            descend(self.actor_optimizer, actor_loss, self.actor.parameters(), max_grad_norm=None)
            soft_update(self.actor, self.actor_target, c.tau)
            soft_update(self.critics, self.critics_target, c.tau)
            metrics["actor_loss"] = float(actor_loss.item())
        if not math.isfinite(metrics["critic_loss"]):
            raise FloatingPointError("the TD3 critic loss is not finite: lower the learning rates")
        return metrics

    def _extra_state(self) -> dict:
        return {"rng": self.rng.bit_generator.state}

    def _load_extra_state(self, state: dict) -> None:
        self.rng.bit_generator.state = state["rng"]
