"""What an agent sees each step: the observation and the actions its observation has not seen yet.

A reading that is d steps old was taken before the last d actions acted. An agent given the observation
plus those d actions sees the augmented state of a delayed MDP (Katsikopoulos and Engelbrecht 2003), which
is Markov again: from it the present state is a function, not a guess. `actions_seen=1` (the default) is
the last action only; choose d from the measured or configured delay with `actions_for_delay`.
"""

from __future__ import annotations

import math
from collections import deque

import gymnasium as gym
import numpy as np

from pendkit.errors import ConfigError

MAX_ACTIONS_SEEN = 16


def action_features(action, action_space) -> np.ndarray:
    """One action as the agent sees it: one-hot for discrete actions, the value for continuous ones."""
    if isinstance(action_space, gym.spaces.Discrete):
        one_hot = np.zeros(action_space.n, dtype=np.float32)
        one_hot[int(action)] = 1.0
        return one_hot
    return np.asarray(action, dtype=np.float32).reshape(action_space.shape)


def null_action(action_space):
    """The action assumed before the first one (stop, or the centre)."""
    return 0 if isinstance(action_space, gym.spaces.Discrete) else np.zeros(action_space.shape, np.float32)


def actions_for_delay(delay_s: float, step_s: float) -> int:
    """How many actions a reading `delay_s` old has not seen: the steps it spans, plus the one in flight."""
    if not (math.isfinite(delay_s) and delay_s >= 0 and step_s > 0):
        raise ConfigError(f"need a finite delay >= 0 and a step > 0, got {delay_s} s and {step_s} s")
    return min(MAX_ACTIONS_SEEN, 1 + math.ceil(delay_s / step_s - 1e-9))


class StepInputs:
    """`reset(observation)` at an episode's start, then `step(observation, action)` after each env step;
    both return the agent's input [observation, last action, ..., d-th last action]. With a fixed
    `encoder` (the reservoir ablation) the input is that encoder's [input, hidden] instead."""

    def __init__(self, observation_dim: int, action_space, actions_seen: int = 1, encoder=None) -> None:
        if not isinstance(actions_seen, int) or not 1 <= actions_seen <= MAX_ACTIONS_SEEN:
            raise ConfigError(f"actions_seen must be an int in [1, {MAX_ACTIONS_SEEN}], got {actions_seen!r}")
        self.action_space, self.actions_seen, self.encoder = action_space, actions_seen, encoder
        self.observation_dim = observation_dim
        self.action_dim = action_features(null_action(action_space), action_space).size
        self.step_dim = observation_dim + actions_seen * self.action_dim
        if encoder is not None and encoder.input_dim != self.step_dim:
            raise ConfigError(f"the encoder takes {encoder.input_dim} inputs, the step has {self.step_dim}")
        self._recent: deque[np.ndarray] = deque(maxlen=actions_seen)

    @classmethod
    def for_env(cls, env, actions_seen: int = 1, encoder=None) -> StepInputs:
        return cls(env.observation_space.shape[0], env.action_space, actions_seen, encoder)

    @property
    def dim(self) -> int:
        return self.encoder.output_dim if self.encoder is not None else self.step_dim

    def reset(self, observation) -> np.ndarray:
        none = action_features(null_action(self.action_space), self.action_space)
        self._recent.extend([none] * self.actions_seen)
        if self.encoder is not None:
            self.encoder.reset()
        return self._make(observation)

    def step(self, observation, action) -> np.ndarray:
        self._recent.appendleft(action_features(action, self.action_space))
        return self._make(observation)

    def _make(self, observation) -> np.ndarray:
        x = np.concatenate([np.asarray(observation, dtype=np.float32).reshape(-1), *self._recent])
        return self.encoder.encode(x) if self.encoder is not None else x
