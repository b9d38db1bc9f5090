"""A discrete agent on the continuous target: `levels` evenly spaced targets from leftmost to rightmost,
sent through the env's filter like any continuous action (the v2 protocol's `b<float>` command).

The firmware's five discrete actions are ramps of the target (speeds); these are positions, as fine as
`levels` makes them: the finer action set a DQN-family learner can use without a protocol change.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from pendkit.errors import ActionError, ConfigError


class TargetLevels(gym.ActionWrapper):
    """`Discrete(levels)` on a continuous-mode env: action k is the target -1 + 2k / (levels - 1)."""

    def __init__(self, env: gym.Env, levels: int) -> None:
        if env.unwrapped.action_mode != "continuous":
            raise ConfigError("target levels need an env made with action_mode='continuous'")
        if not (isinstance(levels, int) and 3 <= levels <= 101 and levels % 2 == 1):
            raise ConfigError(f"levels must be an odd int in [3, 101] (so the centre is one), got {levels!r}")
        super().__init__(env)
        self.targets = np.linspace(-1.0, 1.0, levels, dtype=np.float32)
        self.action_space = gym.spaces.Discrete(levels)

    def action(self, action) -> np.ndarray:
        if isinstance(action, (bool, np.bool_)) or not np.issubdtype(np.asarray(action).dtype, np.integer) \
                or np.asarray(action).size != 1:
            raise ActionError(f"a target level is an integer in [0, {len(self.targets) - 1}], got {action!r}")
        index = int(np.asarray(action).reshape(()))
        if not 0 <= index < len(self.targets):
            raise ActionError(f"target level out of range: expected 0..{len(self.targets) - 1}, got {index}")
        return self.targets[index:index + 1]
