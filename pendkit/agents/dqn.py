"""DQN (Mnih et al. 2015): a Q-network and its target copy, Huber loss, an epsilon schedule, and the
double-DQN target (van Hasselt et al. 2016) as an option."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pendkit.agents.replay import Batch
from pendkit.errors import ConfigError


def mlp(input_dim: int, output_dim: int, hidden: tuple[int, ...]) -> nn.Sequential:
    layers: list[nn.Module] = []
    width = input_dim
    for size in hidden:
        layers += [nn.Linear(width, size), nn.ReLU()]
        width = size
    layers.append(nn.Linear(width, output_dim))
    return nn.Sequential(*layers)


def adam(parameters, learning_rate: float) -> torch.optim.Adam:
    """Adam with the fused kernel where torch has it: with networks this small, per-tensor overhead dominates."""
    parameters = list(parameters)
    try:
        return torch.optim.Adam(parameters, lr=learning_rate, fused=True)
    except (RuntimeError, TypeError):
        return torch.optim.Adam(parameters, lr=learning_rate)


def linear_epsilon(step: int, start: float, end: float, decay_steps: int) -> float:
    """Exploration rate: linear from `start` to `end` over `decay_steps`, then flat."""
    return start + min(1.0, step / decay_steps) * (end - start)


def descend(optimizer: torch.optim.Optimizer, loss: torch.Tensor, parameters, max_grad_norm: float = 10.0) -> None:
    """One optimiser step on `loss`, gradients clipped to `max_grad_norm`."""
    optimizer.zero_grad()
    loss.backward()
    nn.utils.clip_grad_norm_(parameters, max_grad_norm, foreach=True)
    optimizer.step()


@dataclass(frozen=True)
class DqnConfig:
    """DQN settings. The defaults suit the twin: small networks, a short epsilon schedule, and a buffer of
    the last 20 episodes (on the ideal twin, 3 seeds: a 50 000-step buffer took a median of 110 episodes to
    solve, 10 000 took 70, and with epsilon decaying over 2 500 steps instead of 10 000, 50; docs/rl.md)."""

    hidden: tuple[int, ...] = (64, 64)
    learning_rate: float = 1e-3
    gamma: float = 0.98
    batch_size: int = 64
    buffer_capacity: int = 10_000
    learning_starts: int = 500
    target_update_every: int = 250
    epsilon_start: float = 1.0
    epsilon_end: float = 0.05
    epsilon_decay_steps: int = 2_500
    huber_delta: float = 1.0
    double: bool = True
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0 < self.gamma < 1:
            raise ConfigError(f"gamma must be in (0, 1), got {self.gamma}")
        if not 0 <= self.epsilon_end <= self.epsilon_start <= 1:
            raise ConfigError(f"need 0 <= epsilon_end <= epsilon_start <= 1, got {self.epsilon_end}, "
                              f"{self.epsilon_start}")
        for name in ("learning_rate", "batch_size", "buffer_capacity", "target_update_every", "epsilon_decay_steps",
                     "huber_delta"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"{name} must be > 0, got {getattr(self, name)}")


class DqnAgent:
    """`act(observation, explore)`, `update(batch) -> metrics`, `state_dict()`: no env, logger or clock inside."""

    def __init__(self, observation_dim: int, n_actions: int, config: DqnConfig | None = None,
                 parts=None) -> None:
        """`parts`: a `pendkit.agents.lab_parts.StudentParts` whose functions replace the schedule, the
        target or the loss (lab 07)."""
        self.config = config or DqnConfig()
        self.parts = parts
        torch.manual_seed(self.config.seed)
        self.n_actions = n_actions
        self.q = mlp(observation_dim, n_actions, self.config.hidden)
        self.target = mlp(observation_dim, n_actions, self.config.hidden)
        self.target.load_state_dict(self.q.state_dict())
        self.optimizer = adam(self.q.parameters(), self.config.learning_rate)
        self.rng = np.random.default_rng(self.config.seed)
        self.steps = self.updates = 0

    @property
    def epsilon(self) -> float:
        c = self.config
        if self.parts is not None and self.parts.epsilon is not None:
            from pendkit.agents.lab_parts import call_epsilon

            return call_epsilon(self.parts.epsilon, self.steps, c.epsilon_start, c.epsilon_end, c.epsilon_decay_steps)
        return linear_epsilon(self.steps, c.epsilon_start, c.epsilon_end, c.epsilon_decay_steps)

    def act(self, observation, explore: bool = True) -> int:
        if explore:
            self.steps += 1
            if self.rng.random() < self.epsilon:
                return int(self.rng.integers(self.n_actions))
        with torch.no_grad():
            values = self.q(torch.as_tensor(np.asarray(observation, dtype=np.float32)).unsqueeze(0))
        return int(values.argmax(dim=1).item())

    def update(self, batch: Batch) -> dict[str, float]:
        """One gradient step on the TD error; the target network follows every `target_update_every`."""
        c = self.config
        q_taken = self.q(batch.observations).gather(1, batch.actions.unsqueeze(1)).squeeze(1)
        parts = self.parts
        with torch.no_grad():
            if parts is not None and parts.td_target is not None:
                from pendkit.agents.lab_parts import call_td_target

                target = call_td_target(parts.td_target, batch.rewards, batch.dones, self.q(batch.next_observations),
                                        self.target(batch.next_observations), c.gamma, c.double)
            elif c.double:
                best = self.q(batch.next_observations).argmax(dim=1, keepdim=True)
                next_value = self.target(batch.next_observations).gather(1, best).squeeze(1)
                target = batch.rewards + c.gamma * (1.0 - batch.dones) * next_value
            else:
                next_value = self.target(batch.next_observations).max(dim=1).values
                target = batch.rewards + c.gamma * (1.0 - batch.dones) * next_value
        if parts is not None and parts.loss is not None:
            from pendkit.agents.lab_parts import student_loss

            loss = student_loss(parts.loss, q_taken - target, c.huber_delta)
        else:
            loss = nn.functional.huber_loss(q_taken, target, delta=c.huber_delta)
        descend(self.optimizer, loss, self.q.parameters())
        self.updates += 1
        if self.updates % c.target_update_every == 0:
            self.target.load_state_dict(self.q.state_dict())
        value = float(loss.item())
        if not math.isfinite(value):
            raise FloatingPointError("the DQN loss is not finite: lower the learning rate")
        return {"loss": value, "q_mean": float(q_taken.mean().item()), "epsilon": self.epsilon}

    def policy_state(self) -> dict:
        """What an actor needs to act: the Q-network's weights (copied)."""
        return {name: tensor.clone() for name, tensor in self.q.state_dict().items()}

    def load_policy(self, state: dict) -> None:
        self.q.load_state_dict(state)

    def state_dict(self) -> dict:
        return {"q": self.q.state_dict(), "target": self.target.state_dict(),
                "optimizer": self.optimizer.state_dict(), "steps": self.steps, "updates": self.updates,
                "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict) -> None:
        self.q.load_state_dict(state["q"])
        self.target.load_state_dict(state["target"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.steps, self.updates = state["steps"], state["updates"]
        self.rng.bit_generator.state = state["rng"]
