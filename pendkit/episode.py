"""Run an episode with any policy, keep its trace, and plot it."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendkit.backend_contract import RigState
from pendkit.features import (  # time_to_upright_s: read here by the labs
    UPRIGHT_RAD,
    angle_from_upright_rad,
    pendulum_energy,
    time_to_upright_s,  # noqa: F401
)

# pendkit modules that load MuJoCo are imported inside the functions that use them: importing this module does not
# need them (start-up).

Policy = Callable[[np.ndarray, RigState], object]
NO_STATE = RigState(*([math.nan] * len(RigState._fields)))
UNTIL_DONE = 2**62  # `run_episode(steps=UNTIL_DONE)`: until the env says the episode is over
# Colour-blind-safe (Okabe-Ito) colours for every figure the kit draws.
PALETTE = {"pendulum": "#0072B2", "arm": "#E69F00", "action": "#009E73", "reward": "#CC79A7",
           "limit": "#999999"}


@dataclass
class EpisodeTrace:
    """Per-step arrays of one episode (index 0 is the reset)."""

    time_s: list[float] = field(default_factory=list)
    pendulum_from_upright_rad: list[float] = field(default_factory=list)
    pendulum_velocity_rad_s: list[float] = field(default_factory=list)
    arm_angle_rad: list[float] = field(default_factory=list)
    action: list[float] = field(default_factory=list)
    reward: list[float] = field(default_factory=list)

    stopped_by: str | None = None  # what ended the episode early (`run_episode`'s should_stop), if anything
    stopped_at_s: float | None = None

    def add(self, state: RigState | None, time_s: float, action: float, reward: float) -> None:
        """One step; `state` None for an env that is not the kit's (its angles are then NaN)."""
        self.time_s.append(time_s)
        if state is None:
            state = NO_STATE
        self.pendulum_from_upright_rad.append(angle_from_upright_rad(state))
        self.pendulum_velocity_rad_s.append(state.pendulum_velocity_rad_s)
        self.arm_angle_rad.append(state.arm_angle_rad)
        self.action.append(action)
        self.reward.append(reward)

    @property
    def episode_return(self) -> float:
        return float(np.sum(self.reward))

    def as_arrays(self) -> dict[str, np.ndarray]:
        return {name: np.asarray(values) for name, values in self.__dict__.items() if isinstance(values, list)}


def run_episode(env, policy: Policy, *, seed: int | None = None, steps: int | None = None,
                progress: bool = False, options: dict | None = None, started: tuple | None = None,
                should_stop: Callable[[RigState], object] | None = None,
                on_step: Callable[[object, object, float, bool, bool, dict], None] | None = None) -> EpisodeTrace:
    """Run `policy(observation, state) -> action` on `env` for one episode (or `steps` steps): the kit's one
    episode loop (the demo, evaluation, training, lab 09's guarded run). Hooks:

    - `started=(observation, info)`: the caller has reset the env already (e.g. after centring the arm);
    - `should_stop(state)`: asked before each step, a reason (any non-empty text) ends the episode there,
      kept in `trace.stopped_by` with the time in `trace.stopped_at_s` (a watchdog; the caller holds);
    - `on_step(action, observation, reward, terminated, truncated, info)`: after each step (learning).

    `steps=UNTIL_DONE` runs until the env ends the episode, however long its limit.
    """
    dt = getattr(env.unwrapped, "dt", 1.0)  # another Gymnasium env: steps for seconds
    observation, info = started if started is not None else env.reset(seed=seed, options=options)
    if hasattr(policy, "reset"):
        policy.reset(info.get("state"))  # stateful controllers (filters, modes) start afresh
    trace = EpisodeTrace()
    trace.add(info.get("state"), 0.0, 0.0, 0.0)
    limit = steps or episode_limit(env)
    bar = progress_bar(limit, "episode") if progress else None
    try:
        for step in range(1, limit + 1):
            reason = should_stop(info.get("state")) if should_stop is not None else None
            if reason:
                trace.stopped_by, trace.stopped_at_s = str(reason), (step - 1) * dt
                break
            action = policy(observation, info.get("state"))
            observation, reward, terminated, truncated, info = env.step(action)
            trace.add(info.get("state"), step * dt, float(np.asarray(action, dtype=float).reshape(-1)[0]), reward)
            if on_step is not None:
                on_step(action, observation, reward, terminated, truncated, info)
            if bar is not None:
                bar.update(1)
            if terminated or truncated:
                break
    finally:
        if bar is not None:
            bar.close()
    return trace


def episode_limit(env) -> int:
    """Steps in one of `env`'s episodes: the env's own limit, else the registered TimeLimit's, else the
    kit's default."""
    from pendkit.env import EPISODE_STEPS

    own = env.unwrapped.max_episode_steps
    spec = getattr(env, "spec", None)
    return own or (spec.max_episode_steps if spec is not None and spec.max_episode_steps else EPISODE_STEPS)


def energy_pumping_policy(env) -> Policy:
    """A simple discrete policy for demos: swing the arm with the pendulum to pump energy, stop near the top.

    Not a controller worth grading (the control labs build a real one); it shows the rig moving.
    """
    base = env.unwrapped
    near_top_rad = 0.5
    omega0 = base.params.pendulum_natural_frequency_rad_s
    upright_energy = 1.0  # the kit's normalised energy (`pendulum_energy`): -1 hanging still, +1 upright still

    def policy(observation, state: RigState):
        theta = angle_from_upright_rad(state)
        if abs(theta) < near_top_rad:
            return 0
        energy = pendulum_energy(state.pendulum_angle_rad, state.pendulum_velocity_rad_s, omega0)
        pumping = state.pendulum_velocity_rad_s * math.cos(state.pendulum_angle_rad)
        if energy > upright_energy:
            pumping = -pumping  # too much energy: brake instead
        if base.action_mode == "continuous":
            return np.array([-1.0 if pumping > 0 else 1.0], dtype=np.float32)
        return 2 if pumping > 0 else 4

    return policy


def plot_episode(trace: EpisodeTrace, path: str | Path | None = None, title: str = "Episode",
                 natural_frequency_rad_s: float | None = None, decorate=None):
    """Angles, action, reward (and the pendulum's energy, given its natural frequency) against time;
    saved to `path` (PNG) when given. Returns the figure."""
    data = trace.as_arrays()
    rows = 4 if natural_frequency_rad_s else 3
    figure = shown_figure(figsize=(9, 2.2 * rows), layout="constrained")
    axes = figure.subplots(rows, 1, sharex=True)
    t = data["time_s"]
    # |angle| from upright (0 upright, 180 hanging): a signed angle jumps between +-180 at every bottom pass
    axes[0].plot(t, np.degrees(np.abs(data["pendulum_from_upright_rad"])), color=PALETTE["pendulum"],
                 label="pendulum, |from upright|")
    axes[0].plot(t, np.degrees(data["arm_angle_rad"]), color=PALETTE["arm"], linestyle="--", label="arm")
    axes[0].axhspan(0, np.degrees(UPRIGHT_RAD), color=PALETTE["limit"], alpha=0.2, lw=0)
    axes[0].axhline(0, color=PALETTE["limit"], lw=0.8)
    axes[0].set_ylabel("angle (deg)")
    axes[0].legend(loc="upper right")
    axes[1].step(t, data["action"], where="post", color=PALETTE["action"])
    axes[1].set_ylabel("action")
    axes[2].plot(t, data["reward"], color=PALETTE["reward"])
    axes[2].set_ylabel("reward")
    if natural_frequency_rad_s:
        energy = pendulum_energy(data["pendulum_from_upright_rad"] + np.pi, data["pendulum_velocity_rad_s"],
                                 natural_frequency_rad_s)
        axes[3].plot(t, energy, color=PALETTE["pendulum"])
        axes[3].axhline(1.0, color=PALETTE["limit"], lw=0.8, linestyle=":")
        axes[3].set_ylabel("energy (upright = 1)")
    axes[-1].set_xlabel("time (s)")
    figure.suptitle(f"{title}: return {trace.episode_return:.1f}")
    if decorate is not None:
        decorate(axes)  # the caller's additions (the demo's planned trajectories)
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        alt = (f"{title}. Pendulum angle from upright and arm angle in degrees, the action and the reward "
               f"over {t[-1]:.1f} s; episode return {trace.episode_return:.1f}.")
        figure.savefig(path, dpi=110, metadata={"Description": alt})
    return figure


def shown_figure(**options):
    """A matplotlib Figure (no pyplot) that Jupyter draws as a PNG when it is a cell's value, whatever the
    kernel's backend: a bare Figure shows as the text `<Figure size ...>` in ipykernel 7 without it."""
    import io

    from matplotlib.figure import Figure

    class ShownFigure(Figure):
        def _repr_png_(self) -> bytes:
            buffer = io.BytesIO()
            self.savefig(buffer, format="png")
            return buffer.getvalue()

    return ShownFigure(**options)


def progress_bar(total: int, desc: str):
    """A bar over `total` steps (None without tqdm)."""
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    return tqdm(total=total, desc=desc, unit="step", leave=False)
