"""A pure observation delay in whole env steps: the agent sees what the env observed `delay_steps` ago."""

from __future__ import annotations

from collections import deque

import gymnasium as gym

from pendkit.errors import ConfigError


class ObservationDelay(gym.Wrapper):
    """Hand the agent the observation from `delay_steps` steps back (the first one until then).

    Only the observation is delayed: reward, info and the physics are the env's own, so a delay sweep
    changes nothing but what the agent sees. The first observation stands in for the ones not yet arrived;
    gymnasium's `DelayObservation` hands out zeros instead, a feature vector no pendulum can produce, and lab
    08's `delayed_view` (which students write) defines the delay this way.
    """

    def __init__(self, env: gym.Env, delay_steps: int) -> None:
        if not isinstance(delay_steps, int) or not 0 <= delay_steps <= 100:
            raise ConfigError(f"delay_steps must be an int in [0, 100], got {delay_steps!r}")
        super().__init__(env)
        self.delay_steps = delay_steps
        self._pending: deque = deque(maxlen=delay_steps + 1)

    def reset(self, **kwargs):
        observation, info = self.env.reset(**kwargs)
        self._pending.clear()
        self._pending.extend([observation] * (self.delay_steps + 1))
        return self._pending[0], info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        self._pending.append(observation)
        return self._pending[0], reward, terminated, truncated, info
