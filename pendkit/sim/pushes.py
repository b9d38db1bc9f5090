"""Pushes on the twin: a hand tapping the dowel at random moments, as in a class demo or RealAIGym's
real-hardware benchmark (which judges controllers under pushes).

`PendulumPushes(env, size="hand", per_episode=2)` changes the pendulum's rate by the named size, with a
random sign, at `per_episode` random steps of each episode. The pushes fall between `PUSH_WINDOW_STEPS`
(after a swing-up has had time to come up, and early enough that the last 200 steps the kit's "solved"
judges come after the last push), so a solved episode is one that caught every push.

| size    | rate change (rad/s) | what it is like                                      |
|---------|---------------------|------------------------------------------------------|
| `tap`   | 0.5                 | a fingertip on the dowel                             |
| `hand`  | 1.0                 | a deliberate flick with a finger, the usual demo     |
| `shove` | 2.0                 | a palm's push: about a third of a swing's top speed  |
"""

from __future__ import annotations

import gymnasium
import numpy as np

from pendkit.errors import ConfigError

PUSH_SIZES_RAD_S = {"tap": 0.5, "hand": 1.0, "shove": 2.0}
PUSH_WINDOW_STEPS = (150, 300)  # of a 500-step episode: up by then, and the last 200 steps come after
MAX_PUSHES = 10


class PendulumPushes(gymnasium.Wrapper):
    """The twin with `per_episode` pushes of `size` per episode (twin only: a rig is pushed by hand)."""

    def __init__(self, env, size: str = "hand", per_episode: int = 2, seed: int = 0) -> None:
        super().__init__(env)
        if size not in PUSH_SIZES_RAD_S:
            raise ConfigError(f"unknown push size {size!r}; choose from {', '.join(PUSH_SIZES_RAD_S)}")
        if isinstance(per_episode, bool) or not isinstance(per_episode, int) or not 0 <= per_episode <= MAX_PUSHES:
            raise ConfigError(f"per_episode must be a whole number in [0, {MAX_PUSHES}], got {per_episode!r}")
        if not hasattr(env.unwrapped.backend, "push_pendulum"):
            raise ConfigError("pushes need the twin (backend='sim'); on a rig, push the dowel by hand")
        self.size, self.per_episode = size, per_episode
        self.rate_change_rad_s = PUSH_SIZES_RAD_S[size]
        self._rng = np.random.default_rng(seed)
        self._schedule: dict[int, float] = {}
        self._step = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self._rng = np.random.default_rng([seed, 0x9B5])  # apart from the env's own stream
        first, last = PUSH_WINDOW_STEPS
        steps = self._rng.choice(np.arange(first, last), size=self.per_episode, replace=False)
        signs = self._rng.choice([-1.0, 1.0], size=self.per_episode)
        self._schedule = {int(k): float(sign * self.rate_change_rad_s) for k, sign in zip(steps, signs)}
        self._step = 0
        return self.env.reset(seed=seed, options=options)

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)  # a bad action raises first
        push = self._schedule.get(self._step, 0.0)
        if push:  # between two readings: the next observation shows it
            self.env.unwrapped.backend.push_pendulum(push)
        self._step += 1
        return observation, reward, terminated, truncated, {**info, "push_rad_s": push}
