"""TD3 (Fujimoto et al. 2018): a deterministic actor, twin critics with the smaller target, target-policy
smoothing, delayed actor updates and soft target updates. Actions lie in [-1, 1] (the env's continuous
servo target)."""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pendkit.agents.actor_critic import FeedForwardActor
from pendkit.agents.base import ActorCriticConfig
from pendkit.agents.nets import adam, descend, finite, mlp, soft_update
from pendkit.agents.replay import Batch


def explored(agent, action: np.ndarray, explore: bool) -> np.ndarray:
    """A deterministic actor's `action`, with Gaussian exploration noise while exploring, clipped to [-1, 1]."""
    if explore:
        agent.steps += 1
        action = action + agent.rng.normal(0.0, agent.config.exploration_noise, agent.action_dim)
    return np.clip(action, -1.0, 1.0).astype(np.float32)


def delayed_actor_step(agent, critic_loss: torch.Tensor, critic_parameters, actor_loss: Callable[[], torch.Tensor],
                       actor_parameters, targets, name: str) -> dict[str, float]:
    """TD3's optimiser steps: the critics on `critic_loss` every update; every `policy_delay` updates the actor
    on `actor_loss()` and each (network, target) of `targets` a soft step. The losses' values."""
    descend(agent.critic_optimizer, critic_loss, critic_parameters, max_grad_norm=None)
    agent.updates += 1
    metrics = {"critic_loss": float(critic_loss.item())}
    if agent.updates % agent.config.policy_delay == 0:  # the actor (and the targets) move half as often
        loss = actor_loss()
        descend(agent.actor_optimizer, loss, actor_parameters, max_grad_norm=None)
        for network, target in targets:
            soft_update(network, target, agent.config.tau)
        metrics["actor_loss"] = float(loss.item())
    finite(metrics["critic_loss"], f"the {name} critic loss", "lower the learning rates")
    return metrics


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
        self.actor = nn.Sequential(mlp(observation_dim, action_dim, self.config.hidden), nn.Tanh())
        self._twin_critics(observation_dim, action_dim, self.config.critic_learning_rate)
        self.actor_target = copy.deepcopy(self.actor)
        self.actor_optimizer = adam(self.actor.parameters(), self.config.actor_learning_rate)
        self.rng = np.random.default_rng(self.config.seed)

    def act(self, observation, explore: bool = True) -> np.ndarray:
        with torch.no_grad():
            action = self.actor(torch.as_tensor(np.asarray(observation, dtype=np.float32)).unsqueeze(0))[0].numpy()
        return explored(self, action, explore)

    def update(self, batch: Batch) -> dict[str, float]:
        c = self.config
        actions = batch.actions.reshape(len(batch.actions), -1).float()
        with torch.no_grad():
            noise = (torch.randn_like(actions) * c.target_noise).clamp(-c.target_noise_clip, c.target_noise_clip)
            next_actions = (self.actor_target(batch.next_observations) + noise).clamp(-1.0, 1.0)
            next_q = torch.min(*self._q(self.critics_target, batch.next_observations, next_actions))
            target = batch.rewards + c.gamma * (1.0 - batch.dones) * next_q
        q1, q2 = self._q(self.critics, batch.observations, actions)
        return delayed_actor_step(
            self, nn.functional.mse_loss(q1, target) + nn.functional.mse_loss(q2, target), self.critics.parameters(),
            lambda: -self._q(self.critics[:1], batch.observations, self.actor(batch.observations))[0].mean(),
            self.actor.parameters(), [(self.actor, self.actor_target), (self.critics, self.critics_target)], "TD3")

    def _extra_state(self) -> dict:
        return {"rng": self.rng.bit_generator.state}

    def _load_extra_state(self, state: dict) -> None:
        self.rng.bit_generator.state = state["rng"]
