"""What the feed-forward actor-critic agents share (TD3, SAC): twin critics and their targets, the replay
store, and checkpoints of the modules each names."""

from __future__ import annotations

import copy

import torch
from torch import nn

from pendkit.agents.base import Stateless
from pendkit.agents.nets import adam, mlp
from pendkit.agents.replay import ReplayBuffer


class FeedForwardActor(Stateless):
    """A feed-forward actor-critic agent: its policy is `self.actor`'s weights, and its state the modules named
    in `MODULES` plus `steps`, `updates` and what `_extra_state` adds. A subclass seeds torch, builds its
    actor, then `_twin_critics`."""

    MODULES: tuple[str, ...] = ()

    def _twin_critics(self, observation_dim: int, action_dim: int, learning_rate: float) -> None:
        """Two critics of [observation, action], their target copies and optimiser; no steps taken yet."""
        self.input_dim, self.action_dim = observation_dim, action_dim
        self.critics = nn.ModuleList([mlp(observation_dim + action_dim, 1, self.config.hidden) for _ in range(2)])
        self.critics_target = copy.deepcopy(self.critics)
        self.critic_optimizer = adam(self.critics.parameters(), learning_rate)
        self.steps = self.updates = 0

    def new_buffer(self, seed: int = 0) -> ReplayBuffer:
        return ReplayBuffer(self.config.buffer_capacity, self.input_dim, seed, action_dim=self.action_dim)

    def _q(self, critics, observations, actions) -> list[torch.Tensor]:
        joined = torch.cat([observations, actions], dim=1)
        return [critic(joined).squeeze(1) for critic in critics]

    def policy_state(self) -> dict:
        """What an actor needs to act: the actor network's weights (copied)."""
        return {name: tensor.clone() for name, tensor in self.actor.state_dict().items()}

    def load_policy(self, state: dict) -> None:
        self.actor.load_state_dict(state)

    def state_dict(self) -> dict:
        return {name: getattr(self, name).state_dict() for name in self.MODULES} | {
            "steps": self.steps, "updates": self.updates} | self._extra_state()

    def load_state_dict(self, state: dict) -> None:
        for name in self.MODULES:
            getattr(self, name).load_state_dict(state[name])
        self.steps, self.updates = state["steps"], state["updates"]
        self._load_extra_state(state)

    def _extra_state(self) -> dict:
        return {}

    def _load_extra_state(self, state: dict) -> None:
        pass
