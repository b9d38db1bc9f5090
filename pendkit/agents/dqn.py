"""DQN (Mnih et al. 2015): a Q-network and its target copy, Huber loss, an epsilon schedule, and the
double-DQN target (van Hasselt et al. 2016) as an option.

The schedule, the target and the loss are callables defaulting to the kit's own (`linear_epsilon`,
`td_target`, `huber_loss`); lab 07 passes a student's versions in (`pendkit.labs.dqn_parts`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from pendkit.agents.base import EpsilonGreedyConfig, Stateless
from pendkit.agents.nets import adam, descend, finite, mlp
from pendkit.agents.replay import Batch, ReplayBuffer


def linear_epsilon(step: int, start: float, end: float, decay_steps: int) -> float:
    """Exploration rate: linear from `start` to `end` over `decay_steps`, then flat."""
    return start + min(1.0, step / decay_steps) * (end - start)


def td_target(rewards: torch.Tensor, dones: torch.Tensor, next_q_online: torch.Tensor, next_q_target: torch.Tensor,
              gamma: float, double: bool) -> torch.Tensor:
    """r + gamma (1 - done) Q'(s', a*): a* the online network's choice (double) or the target's own max."""
    if double:
        next_value = next_q_target.gather(1, next_q_online.argmax(dim=1, keepdim=True)).squeeze(1)
    else:
        next_value = next_q_target.max(dim=1).values
    return rewards + gamma * (1.0 - dones) * next_value


def huber_loss(errors: torch.Tensor, delta: float) -> torch.Tensor:
    """Mean Huber loss of the TD errors (Q - target)."""
    return nn.functional.huber_loss(errors, torch.zeros_like(errors), delta=delta)


def q_learning_step(agent, loss: torch.Tensor, name: str) -> float:
    """One optimiser step of a Q-learner (`agent.q`, `.target`, `.optimizer`, `.updates`) on `loss`, the target
    network a copy of the online one every `target_update_every` updates: the loss's value."""
    descend(agent.optimizer, loss, agent.q.parameters())
    agent.updates += 1
    if agent.updates % agent.config.target_update_every == 0:
        agent.target.load_state_dict(agent.q.state_dict())
    return finite(float(loss.item()), f"the {name} loss")


@dataclass(frozen=True)
class DqnConfig(EpsilonGreedyConfig):
    """DQN settings. The defaults suit the twin: small networks, a short epsilon schedule, and a buffer of
    the last 20 episodes (on the ideal twin, 3 seeds: a 50 000-step buffer took a median of 110 episodes to
    solve, 10 000 took 70, and with epsilon decaying over 2 500 steps instead of 10 000, 50; docs/rl.md)."""

    double: bool = True


class DqnAgent(Stateless):
    """`act(observation, explore)`, `update(batch) -> metrics`, `state_dict()`: no env, logger or clock inside."""

    def __init__(self, observation_dim: int, n_actions: int, config: DqnConfig | None = None, *,
                 epsilon: Callable[[int, float, float, int], float] = linear_epsilon,
                 target: Callable[..., torch.Tensor] = td_target,
                 loss: Callable[[torch.Tensor, float], torch.Tensor] = huber_loss) -> None:
        """`epsilon(step, start, end, decay_steps)`, `target(rewards, dones, next_q_online, next_q_target, gamma,
        double)` and `loss(errors, delta)` replace the kit's schedule, TD target and loss."""
        self.config = config or DqnConfig()
        self.epsilon_schedule, self.target_rule, self.loss_rule = epsilon, target, loss
        torch.manual_seed(self.config.seed)
        self.input_dim, self.n_actions = observation_dim, n_actions
        self.q = mlp(observation_dim, n_actions, self.config.hidden)
        self.target = mlp(observation_dim, n_actions, self.config.hidden)
        self.target.load_state_dict(self.q.state_dict())
        self.optimizer = adam(self.q.parameters(), self.config.learning_rate)
        self.rng = np.random.default_rng(self.config.seed)
        self.steps = self.updates = 0

    def new_buffer(self, seed: int = 0) -> ReplayBuffer:
        return ReplayBuffer(self.config.buffer_capacity, self.input_dim, seed)

    @property
    def epsilon(self) -> float:
        c = self.config
        return self.epsilon_schedule(self.steps, c.epsilon_start, c.epsilon_end, c.epsilon_decay_steps)

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
        with torch.no_grad():
            target = self.target_rule(batch.rewards, batch.dones, self.q(batch.next_observations),
                                      self.target(batch.next_observations), c.gamma, c.double)
        value = q_learning_step(self, self.loss_rule(q_taken - target, c.huber_delta), "DQN")
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
