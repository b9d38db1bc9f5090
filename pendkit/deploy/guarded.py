"""Running a controller on a rig with a watchdog: every step, before the policy acts, a safety check may
stop the run. On a stop the servo holds where it is (discrete "stop", or the current target) and the run
ends: a failing link or an impossible reading is caught by the check, not by the hardware.

A rig's reset does not move the arm (the authors' rig holds the servo while the pendulum settles), so a
continuous-action run first brings the arm back to the centre and lets the pendulum settle again."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pendkit.backend_contract import RigState
from pendkit.episode import EpisodeTrace, Policy, progress_bar

CENTRED_RAD, CENTRING_S = 0.1, 1.5
Watchdog = Callable[[float, float, float], object]  # (arm rad, pendulum rate rad/s, observation age s) -> reason


@dataclass
class GuardedRun:
    trace: EpisodeTrace
    stop_reason: str | None  # what the watchdog said, or None when the run went to its end
    stopped_at_s: float | None


def hold_action(env, state: RigState):
    """The action that keeps the servo where it is now."""
    base = env.unwrapped
    if base.action_mode == "discrete":
        return 0
    return np.array([np.clip(state.servo_target_rad / base.params.servo_range_rad, -1, 1)], dtype=np.float32)


def run_guarded(env, policy: Policy, should_stop: Watchdog, *, steps: int, seed: int | None = None,
                options: dict | None = None, progress: bool = False) -> GuardedRun:
    """`run_episode` with a watchdog: `should_stop(arm_angle_rad, pendulum_velocity_rad_s,
    observation_age_s)` returns a reason (any non-empty text) to stop, or None to go on. `progress`: a bar
    over the steps (a rig runs in real time: 500 steps are 30 s)."""
    bar = progress_bar(steps, "steps") if progress else None
    try:
        return _run_guarded(env, policy, should_stop, steps, seed, options, bar)
    finally:
        if bar is not None:
            bar.close()


def _run_guarded(env, policy: Policy, should_stop: Watchdog, steps: int, seed: int | None, options: dict | None,
                 bar) -> GuardedRun:
    observation, info = env.reset(seed=seed, options=options)
    if env.unwrapped.action_mode == "continuous" and abs(info["state"].arm_angle_rad) > CENTRED_RAD:
        for _ in range(int(CENTRING_S / env.unwrapped.dt)):
            _, _, _, _, info = env.step(np.zeros(1, dtype=np.float32))
        observation, info = env.reset(seed=seed, options=options)
    if hasattr(policy, "reset"):
        policy.reset(info["state"])
    trace = EpisodeTrace()
    trace.add(info["state"], 0.0, 0.0, 0.0)
    dt = env.unwrapped.dt
    for step in range(1, steps + 1):
        state = info["state"]
        reason = should_stop(state.arm_angle_rad, state.pendulum_velocity_rad_s, state.observation_age_s)
        if reason:
            try:
                env.step(hold_action(env, state))
            except Exception as error:  # noqa: BLE001 - the link may be what failed; the servo keeps its target
                reason = f"{reason} (the hold command failed too: {type(error).__name__})"
            return GuardedRun(trace, str(reason), (step - 1) * dt)
        action = policy(observation, state)
        observation, reward, terminated, truncated, info = env.step(action)
        trace.add(info["state"], step * dt, float(np.asarray(action, dtype=float).reshape(-1)[0]), reward)
        if bar is not None:
            bar.update(1)
        if terminated or truncated:
            break
    return GuardedRun(trace, None, None)
