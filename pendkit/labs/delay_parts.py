"""Lab 08's pieces inside the kit: the student's `delayed_view` is the delay the three agents learn behind,
and the student's `gru_step` is the cell a trained R-DQN acts through. A wrong piece changes what the
agents see or what the policy does, which is the point.

- `delayed_view(observations, delay_steps) -> array`: row t is what an agent sees at step t;
- `gru_step(x, h, w_ih, w_hh, b_ih, b_hh) -> h'`: one GRU step in PyTorch's gate layout.
"""

from __future__ import annotations

from collections.abc import Callable

import gymnasium as gym
import numpy as np
import torch

from pendkit.labs.agent_parts import StudentCodeError


class StudentDelay(gym.Wrapper):
    """The env seen through a student's `delayed_view`: each step, the episode's observations so far go in
    and the last row of the answer is what the agent gets (reward, info and physics are the env's own).
    `delay_steps` is exposed as `ObservationDelay` exposes it, so a delay-aware agent sizes its inputs."""

    def __init__(self, env: gym.Env, fn: Callable, delay_steps: int) -> None:
        super().__init__(env)
        self.fn, self.delay_steps = fn, delay_steps
        self._history: list[np.ndarray] = []

    def reset(self, **kwargs):
        observation, info = self.env.reset(**kwargs)
        self._history = [np.asarray(observation, dtype=np.float32)]
        return self._seen(), info

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        self._history.append(np.asarray(observation, dtype=np.float32))
        return self._seen(), reward, terminated, truncated, info

    def _seen(self) -> np.ndarray:
        history = np.array(self._history)
        try:
            rows = np.asarray(self.fn(history.copy(), self.delay_steps), dtype=np.float32)
        except Exception as error:
            raise StudentCodeError(f"your delayed_view raised {error!r} on {len(history)} observations") from error
        if rows.shape != history.shape:
            raise StudentCodeError(f"your delayed_view returned shape {rows.shape} for observations of shape "
                                   f"{history.shape}: one row per step")
        return np.clip(rows[-1], self.observation_space.low, self.observation_space.high)


def steps_late(fn: Callable, delay_steps: int, rows: int = 16) -> int | None:
    """How many steps late the student's `delayed_view(observations, delay_steps)` shows a ramp (None when its
    answer is not the ramp shifted by a whole number of steps, or it raises)."""
    ramp = np.arange(rows, dtype=float)[:, None]
    try:
        seen = np.asarray(fn(ramp.copy(), delay_steps), dtype=float).reshape(ramp.shape)
    except Exception:  # noqa: BLE001 (the student's code: the cell that calls it shows its error)
        return None
    return next((k for k in range(rows) if np.array_equal(seen, ramp[np.maximum(0, np.arange(rows) - k)])), None)


def delay_said(fn: Callable, delay_steps: int, dt_s: float) -> str | None:
    """None when `fn` delays by `delay_steps`; else what delay it gives instead, in words."""
    late = steps_late(fn, delay_steps)
    if late == delay_steps:
        return None
    asked = f"delayed_view(observations, {delay_steps}) should show each step {delay_steps} steps late " \
            f"({1000 * delay_steps * dt_s:.0f} ms)"
    if late is None:
        return f"your {asked}; it is not a delay of a whole number of steps"
    steps = "1 step" if late == 1 else f"{late} steps"
    return f"your {asked}; it shows them {steps} late ({1000 * late * dt_s:.0f} ms)"


def student_gru_cell(fn: Callable, trunk) -> Callable:
    """A `GruTrunk.step` replacement that runs the student's `gru_step` on the trunk's own weights."""
    gru = trunk.gru
    weights = [p.detach().double().numpy() for p in (gru.weight_ih_l0, gru.weight_hh_l0, gru.bias_ih_l0,
                                                      gru.bias_hh_l0)]

    def step(inputs: torch.Tensor, hidden: torch.Tensor) -> torch.Tensor:
        rows = []
        for x, h in zip(inputs.double().numpy(), hidden.double().numpy()):
            try:
                out = np.asarray(fn(x, h, *weights), dtype=np.float64)
            except Exception as error:
                raise StudentCodeError(f"your gru_step raised {error!r}") from error
            if out.shape != h.shape or not np.all(np.isfinite(out)):
                raise StudentCodeError(f"your gru_step returned {out.shape}, expected a finite {h.shape}")
            rows.append(out)
        return torch.as_tensor(np.array(rows), dtype=torch.float32)

    return step


def policy_with_cell(name: str, env, gru_step: Callable | None = None):
    """The shipped recurrent policy `name` on `env`, acting through `gru_step` (None: the kit's own cell)."""
    from pendkit.agents.pretrained import load_policy

    policy = load_policy(name, env)
    if gru_step is not None:
        trunk = policy.agent.q.trunk
        trunk.step = student_gru_cell(gru_step, trunk)
    return policy
