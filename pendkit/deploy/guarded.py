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
from pendkit.episode import EpisodeTrace, Policy, run_episode

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
    observation_age_s)` returns a reason (any non-empty text) to stop, or None to go on; on a stop the servo
    is told to hold. `progress`: a bar over the steps (a rig runs in real time: 500 steps are 30 s)."""
    started = env.reset(seed=seed, options=options)
    if env.unwrapped.action_mode == "continuous" and abs(started[1]["state"].arm_angle_rad) > CENTRED_RAD:
        for _ in range(int(CENTRING_S / env.unwrapped.dt)):
            env.step(np.zeros(1, dtype=np.float32))
        started = env.reset(seed=seed, options=options)
    checked: list[RigState] = []

    def watchdog(state: RigState):
        checked.append(state)
        return should_stop(state.arm_angle_rad, state.pendulum_velocity_rad_s, state.observation_age_s)

    trace = run_episode(env, policy, steps=steps, progress=progress, started=started, should_stop=watchdog)
    if trace.stopped_by is None:
        return GuardedRun(trace, None, None)
    reason = trace.stopped_by
    try:
        env.step(hold_action(env, checked[-1]))
    except Exception as error:  # noqa: BLE001 - the link may be what failed; the servo keeps its target
        reason = f"{reason} (the hold command failed too: {type(error).__name__})"
    return GuardedRun(trace, reason, trace.stopped_at_s)
