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


# Lab 08's Task 4 asked of the sweep file three ways: (what is asked, the episode budget counted or None for the
# file's whole budget, the threshold). The file's rates are 0 or 1 at its whole budget, so the second and third
# ways are where a comparison that differs from the task's wording gives another delay: `<=` or `>` at the
# threshold shows at 1.0 (every seed), and forgetting the other agent shows within 200 episodes, where R-DQN's
# seeds at 120 ms had not all got there yet.
ASKED = (("half the seeds (threshold 0.5), whole budget", None, 0.5),
         ("every seed (threshold 1.0), whole budget", None, 1.0),
         ("half the seeds, within 200 episodes", 200, 0.5))


def rates_within(record: dict, episodes: int | None) -> dict[str, list[float]]:
    """Per agent, at each delay of a delay-sweep record (`pendkit/data/delay_sweep.json`), the share of seeds that
    reached the rule within `episodes` episodes (None: within the sweep's own budget)."""
    rates: dict[str, list[float]] = {}
    for run in record["runs"]:
        reached = [n is not None and (episodes is None or n <= episodes) for n in run["episodes"]]
        rates.setdefault(run["algo"], []).append(sum(reached) / len(reached))
    return rates


def first_break(delays_ms, plain_rates, other_rates, threshold: float = 0.5):
    """Task 4 as worded: the first delay where plain < threshold <= other, or None."""
    return next((d for d, p, o in zip(delays_ms, plain_rates, other_rates) if p < threshold <= o), None)


def breaking_delay_lines(fn: Callable, record: dict | None = None) -> list[str]:
    """The student's `breaking_delay` on the sweep file asked three ways (`ASKED`), each beside the answer the
    task's wording gives, marked where they differ. Raises what `fn` raises."""
    import json

    from pendkit.agents.results import DATA

    record = record or json.loads((DATA / "delay_sweep.json").read_text())
    delays, budget = list(record["delays_ms"]), record["max_episodes"]
    lines = []
    for asked, episodes, threshold in ASKED:
        rates = rates_within(record, episodes)
        label = asked.replace("whole budget", f"{budget} episodes")
        for other in (name for name in ("dqn+actions", "r-dqn") if name in rates):
            yours = fn(delays, rates["dqn"], rates[other], threshold)
            wording = first_break(delays, rates["dqn"], rates[other], threshold)
            shown = [("None" if value is None else f"{value:g} ms") for value in (yours, wording)]
            lines.append(f"{label:<46} {other:<12} yours {shown[0]:>7}, as the task words it {shown[1]:>7}"
                         + ("" if yours == wording else "  <- they differ"))
    return lines
