"""SAC (Haarnoja et al. 2018, with the automatic temperature of the follow-up paper): a squashed Gaussian
actor that maximises return plus entropy, twin critics with the smaller target, soft target updates and a
temperature tuned so the policy's entropy stays near -action_dim. Actions lie in [-1, 1] (the env's
continuous servo target); acting greedily is tanh of the actor's mean."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pendkit.agents.actor_critic import FeedForwardActor
from pendkit.agents.base import SoftTargetConfig
from pendkit.agents.nets import adam, descend, finite, mlp, soft_update
from pendkit.agents.replay import Batch

LOG_STD_MIN, LOG_STD_MAX = -20.0, 2.0


@dataclass(frozen=True)
class SacConfig(SoftTargetConfig):
    """`learning_rate` for actor, critics and temperature alike; `initial_temperature`: the entropy weight
    before tuning."""

    batch_size: int = 128
    buffer_capacity: int = 100_000
    learning_starts: int = 1000
    learning_rate: float = 1e-3
    initial_temperature: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        self._positive("learning_rate", "initial_temperature")


class SacAgent(FeedForwardActor):
    """`act(observation, explore)` -> action array in [-1, 1]; `update(batch)`; `state_dict()`."""

    MODULES = ("actor", "critics", "critics_target", "actor_optimizer", "critic_optimizer", "temperature_optimizer")

    def __init__(self, observation_dim: int, action_dim: int, config: SacConfig | None = None) -> None:
        self.config = config or SacConfig()
        torch.manual_seed(self.config.seed)
        self.actor = mlp(observation_dim, 2 * action_dim, self.config.hidden)  # mean and log std
        self._twin_critics(observation_dim, action_dim, self.config.learning_rate)
        self.log_temperature = torch.tensor([math.log(self.config.initial_temperature)], requires_grad=True)
        self.actor_optimizer = adam(self.actor.parameters(), self.config.learning_rate)
        self.temperature_optimizer = torch.optim.Adam([self.log_temperature], lr=self.config.learning_rate)
        self.target_entropy = -float(action_dim)
        self.generator = torch.Generator().manual_seed(self.config.seed)

    def _sample(self, observations: torch.Tensor, generator=None) -> tuple[torch.Tensor, torch.Tensor]:
        """(actions in [-1, 1], their log-probabilities) drawn from the squashed Gaussian."""
        mean, log_std = self.actor(observations).chunk(2, dim=1)
        std = log_std.clamp(LOG_STD_MIN, LOG_STD_MAX).exp()
        noise = torch.randn(mean.shape, generator=generator) if generator is not None else torch.randn_like(mean)
        raw = mean + std * noise
        action = torch.tanh(raw)
        log_prob = (-0.5 * noise.pow(2) - std.log() - 0.5 * math.log(2 * math.pi)).sum(dim=1)
        log_prob = log_prob - torch.log(1.0 - action.pow(2) + 1e-6).sum(dim=1)  # the tanh's change of volume
        return action, log_prob

    def act(self, observation, explore: bool = True) -> np.ndarray:
        x = torch.as_tensor(np.asarray(observation, dtype=np.float32)).unsqueeze(0)
        with torch.no_grad():
            if explore:
                self.steps += 1
                action = self._sample(x, self.generator)[0][0]
            else:
                action = torch.tanh(self.actor(x).chunk(2, dim=1)[0][0])
        return action.numpy().astype(np.float32)

    def update(self, batch: Batch) -> dict[str, float]:
        c = self.config
        actions = batch.actions.reshape(len(batch.actions), -1).float()
        temperature = self.log_temperature.exp().detach()
        with torch.no_grad():
            next_actions, next_log_prob = self._sample(batch.next_observations)
            next_q = torch.min(*self._q(self.critics_target, batch.next_observations, next_actions))
            target = batch.rewards + c.gamma * (1.0 - batch.dones) * (next_q - temperature * next_log_prob)
        q1, q2 = self._q(self.critics, batch.observations, actions)
        critic_loss = nn.functional.mse_loss(q1, target) + nn.functional.mse_loss(q2, target)
        descend(self.critic_optimizer, critic_loss, self.critics.parameters(), max_grad_norm=None)
        new_actions, log_prob = self._sample(batch.observations)
        q_new = torch.min(*self._q(self.critics, batch.observations, new_actions))
        actor_loss = (temperature * log_prob - q_new).mean()
        descend(self.actor_optimizer, actor_loss, self.actor.parameters(), max_grad_norm=None)
        temperature_loss = -(self.log_temperature * (log_prob.detach() + self.target_entropy)).mean()
        descend(self.temperature_optimizer, temperature_loss, [self.log_temperature], max_grad_norm=None)
        soft_update(self.critics, self.critics_target, c.tau)
        self.updates += 1
        metrics = {"critic_loss": float(critic_loss.item()), "actor_loss": float(actor_loss.item()),
                   "temperature": float(temperature.item())}
        finite(metrics["critic_loss"], "the SAC critic loss")
        return metrics

    def _extra_state(self) -> dict:
        return {"log_temperature": self.log_temperature.detach().clone(), "generator": self.generator.get_state()}

    def _load_extra_state(self, state: dict) -> None:
        with torch.no_grad():
            self.log_temperature.copy_(state["log_temperature"])
        self.generator.set_state(state["generator"])
