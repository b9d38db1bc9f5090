"""The agent contract: what the trainers (`train.train_sync`, `async_trainer.AsyncTrainer`), the shipped
policies and the CLI rely on, and the settings every off-policy learner shares.

An agent acts on one input vector per step (built by `pendkit.agents.inputs.StepInputs`), learns from
the replay store it makes itself, and keeps no env, logger or clock inside. A recurrent agent carries a
state across an episode: `reset()` clears it and `step_extras()` hands the trainer what its store keeps
with each step (the state before the step, for stored-state replay). A feed-forward agent's `reset` and
`track_input` do nothing and its extras are empty, so the trainers need no `if recurrent` of their own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

from pendkit.errors import ConfigError


@dataclass(frozen=True)
class OffPolicyConfig:
    """Settings every learner has. `update_every`: env steps per gradient step once `learning_starts`
    transitions are stored; `hidden`: the widths of the fully connected layers."""

    hidden: tuple[int, ...] = (64, 64)
    gamma: float = 0.98
    batch_size: int = 64
    buffer_capacity: int = 10_000
    learning_starts: int = 500
    update_every: int = 1
    seed: int = 0

    def __post_init__(self) -> None:
        if not 0 < self.gamma < 1:
            raise ConfigError(f"gamma must be in (0, 1), got {self.gamma}")
        if self.learning_starts < 0:
            raise ConfigError(f"learning_starts must be >= 0, got {self.learning_starts}")
        self._positive("batch_size", "buffer_capacity", "update_every")

    def _positive(self, *names: str) -> None:
        for name in names:
            if not getattr(self, name) > 0:
                raise ConfigError(f"{name} must be > 0, got {getattr(self, name)}")


@dataclass(frozen=True)
class EpsilonGreedyConfig(OffPolicyConfig):
    """A Q-learner's settings: epsilon linear from start to end over `epsilon_decay_steps`, a target network
    copied every `target_update_every` updates, the Huber loss."""

    learning_rate: float = 1e-3
    target_update_every: int = 250
    epsilon_start: float = 1.0
    epsilon_end: float = 0.05
    epsilon_decay_steps: int = 2_500
    huber_delta: float = 1.0

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0 <= self.epsilon_end <= self.epsilon_start <= 1:
            raise ConfigError(f"need 0 <= epsilon_end <= epsilon_start <= 1, got {self.epsilon_end}, "
                              f"{self.epsilon_start}")
        self._positive("learning_rate", "target_update_every", "epsilon_decay_steps", "huber_delta")


@dataclass(frozen=True)
class SoftTargetConfig(OffPolicyConfig):
    """An actor-critic learner's settings: target networks that follow at `tau` per update."""

    tau: float = 0.005

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0 < self.tau <= 1:
            raise ConfigError(f"tau must be in (0, 1], got {self.tau}")


@dataclass(frozen=True)
class ActorCriticConfig(SoftTargetConfig):
    """TD3's settings (Fujimoto et al. 2018): soft targets, Gaussian exploration, target-policy smoothing, the
    actor updated every `policy_delay` critic updates."""

    actor_learning_rate: float = 1e-3
    critic_learning_rate: float = 1e-3
    exploration_noise: float = 0.1
    target_noise: float = 0.2
    target_noise_clip: float = 0.5
    policy_delay: int = 2

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.policy_delay < 1 or min(self.exploration_noise, self.target_noise, self.target_noise_clip) < 0:
            raise ConfigError("policy_delay must be >= 1 and the noise settings >= 0")
        self._positive("actor_learning_rate", "critic_learning_rate")


@dataclass(frozen=True)
class SequenceConfig(OffPolicyConfig):
    """A recurrent learner's settings: the GRU's size and each replayed stretch (burn-in + trained steps)."""

    gru_size: int = 32
    burn_in: int = 8
    sequence_length: int = 8
    buffer_capacity: int = 100_000  # whole episodes' stretches, ten times a step learner's

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.burn_in < 0:
            raise ConfigError(f"burn_in must be >= 0, got {self.burn_in}")
        self._positive("gru_size", "sequence_length")


@runtime_checkable
class ReplayStore(Protocol):
    """What an agent learns from: `add` every step, `sample` a batch the agent's `update` takes."""

    def __len__(self) -> int: ...

    def add(self, x, action, reward: float, x_next, done: bool, *, episode: int, step: int, **extras) -> None: ...

    def sample(self, batch_size: int) -> Any: ...

    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...


@runtime_checkable
class Agent(Protocol):
    """The contract both trainers use, step by step:

        agent.reset()                      # an episode starts
        agent.track_input(x)               # (learning only) fold x into the input statistics
        action = agent.act(x, explore)     # one step
        store.add(x, action, ..., **agent.step_extras())
        agent.update(store.sample(agent.config.batch_size))   # every config.update_every steps
    """

    config: OffPolicyConfig
    input_dim: int

    def reset(self) -> None: ...

    def track_input(self, x) -> None: ...

    def act(self, x, explore: bool = True): ...

    def step_extras(self) -> dict: ...

    def new_buffer(self, seed: int = 0) -> ReplayStore: ...

    def update(self, batch) -> dict[str, float]: ...

    def policy_state(self) -> dict: ...

    def load_policy(self, state: dict) -> None: ...

    def state_dict(self) -> dict: ...

    def load_state_dict(self, state: dict) -> None: ...


class Stateless:
    """The episode hooks of a feed-forward agent: nothing to reset, track or store beside a step."""

    def reset(self) -> None:
        pass

    def track_input(self, x) -> None:
        pass

    def step_extras(self) -> dict:
        return {}
