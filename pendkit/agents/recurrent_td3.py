"""R-TD3 with a trained GRU encoder: TD3 whose actor and critics see [input, GRU state].

What the paper states: as R-DQN, a GRU encodes the episode so far, one step per env step, and its vector
joined to the current observation is the networks' input. What we chose: one GRU, trained by the critics'
TD loss over re-encoded replay stretches (stored state plus burn-in, as in our R-DQN); the actor reads the
GRU's state without sending gradient into it, so the encoder learns what predicts value and the actor
does not pull it towards whatever flatters the critic. Inputs are normalised with running statistics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pendkit.agents.base import ActorCriticConfig, SequenceConfig
from pendkit.agents.nets import adam, masked_mean, mlp
from pendkit.agents.recurrent import GruTrunk, RecurrentAgent, device_network
from pendkit.agents.sequence_replay import SequenceBatch
from pendkit.agents.td3 import delayed_actor_step, explored
from pendkit.device.blob_parts import NetworkBlob


@dataclass(frozen=True)
class RecurrentTd3Config(SequenceConfig, ActorCriticConfig):
    batch_size: int = 32
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


class RecurrentTd3Agent(RecurrentAgent):
    """`reset()` per episode; `act(x)` advances the GRU; `update(SequenceBatch)`; `state_dict()`;
    `device_network()`: the actor as the device runs it."""

    NETWORK, OPTIMIZERS = "net", ("actor_optimizer", "critic_optimizer")

    def __init__(self, input_dim: int, action_dim: int, config: RecurrentTd3Config | None = None) -> None:
        self.config = c = config or RecurrentTd3Config()
        torch.manual_seed(c.seed)
        self._start(input_dim, RecurrentActorCritic(input_dim, action_dim, c.gru_size, c.hidden), action_dim)
        self.actor_optimizer = adam(self.net.actor.parameters(), c.actor_learning_rate)
        self.critic_optimizer = adam([*self.net.trunk.parameters(), *self.net.critics.parameters()],
                                     c.critic_learning_rate)

    def act(self, x, explore: bool = True) -> np.ndarray:
        with torch.no_grad():
            z = self._advance(x)
            action = self.net.actor(torch.cat([z, self.hidden], dim=-1))[0].numpy()
        return explored(self, action, explore)

    def update(self, batch: SequenceBatch) -> dict[str, float]:
        c, b = self.config, self.config.burn_in
        x_t, x_next, online_h, target_h = self._replayed(batch)
        mask = batch.loss_mask[:, b:]
        actions = batch.actions[:, b:].reshape(*x_t.shape[:2], -1).float()
        with torch.no_grad():
            next_features = torch.cat([x_next, self.target.trunk.step_all(x_next, target_h)], dim=-1)
            noise = (torch.randn_like(actions) * c.target_noise).clamp(-c.target_noise_clip, c.target_noise_clip)
            next_actions = (self.target.actor(next_features) + noise).clamp(-1.0, 1.0)
            next_q = torch.min(*self.target.q(next_features, next_actions))
            target = batch.rewards[:, b:] + c.gamma * (1.0 - batch.dones[:, b:]) * next_q
        features = torch.cat([x_t, online_h], dim=-1)
        q1, q2 = self.net.q(features, actions)
        detached = features.detach()
        return delayed_actor_step(
            self, masked_mean((q1 - target) ** 2 + (q2 - target) ** 2, mask), [],
            lambda: -masked_mean(self.net.q(detached, self.net.actor(detached), self.net.critics[:1])[0], mask),
            [], [(self.net, self.target)], "R-TD3")

    def device_network(self) -> NetworkBlob:
        """The actor as the device runs it: the GRU, then [input, GRU state] through the actor's layers to the
        tanh-bounded target."""
        modules = [m for m in self.net.actor.modules() if not list(m.children())]  # Linear, ReLU, ..., Tanh
        return device_network(self.net.trunk, modules, self.normalizer, "continuous")
