"""Excitation episodes: open-loop action schedules that make a rig's parameters visible in the pendulum's
encoder (a hobby servo reports nothing of its arm).

Each episode starts from rest, drives the arm for 12 steps in a square wave of slow or fast moves, then
stops and lets the pendulum swing freely for 90 (over 4 of its periods). The half-periods differ from
episode to episode and stay off the pendulum's own (about 10 steps), and fast and slow moves alternate,
so the recorded swings carry
the servo's speed and torque (how fast the arm follows a fast ramp), the loop delay (the phase of the
response), the pendulum's natural frequency and its damping (the free swing). Amplitudes stay within about
1 rad, well short of a swing-up: the response stays smooth enough for a twin to follow it step by step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

STOP, LEFT_SLOW, LEFT_FAST, RIGHT_SLOW, RIGHT_FAST = range(5)
# (half-period in steps, fast moves), one per episode, cycled
EPISODES = ((3, True), (5, False), (4, True), (12, False), (3, False), (6, True), (5, True), (14, False),
            (4, False), (7, True))


@dataclass(frozen=True)
class Excitation:
    """One episode's schedule: `drive_steps` of a square wave with `half_period_steps`, then stops."""

    half_period_steps: int
    fast: bool = True
    drive_steps: int = 12
    free_steps: int = 90

    def actions(self) -> list[int]:
        right, left = (RIGHT_FAST, LEFT_FAST) if self.fast else (RIGHT_SLOW, LEFT_SLOW)
        drive = [right if (k // self.half_period_steps) % 2 == 0 else left for k in range(self.drive_steps)]
        return drive + [STOP] * self.free_steps


def schedule(episodes: int) -> list[Excitation]:
    return [Excitation(*EPISODES[k % len(EPISODES)]) for k in range(episodes)]


@dataclass
class Recording:
    """What one excitation episode gave: the actions sent, the servo target the host knows at the start,
    and per step the pendulum's encoder angle (rad from the bottom) and the reading's rate (rad/s)."""

    actions: list[int]
    start_servo_target_rad: float
    start_pendulum_rad: float
    pendulum_rad: list[float] = field(default_factory=list)
    pendulum_velocity_rad_s: list[float] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {"actions": self.actions, "start_servo_target_rad": self.start_servo_target_rad,
                "start_pendulum_rad": self.start_pendulum_rad, "pendulum_rad": self.pendulum_rad,
                "pendulum_velocity_rad_s": self.pendulum_velocity_rad_s}

    @classmethod
    def from_dict(cls, record: dict) -> Recording:
        return cls(**record)


def record(env, excitation: Excitation, seed: int = 0) -> Recording:
    """Run one excitation episode on `env` (a discrete-action env: twin or rig), reading only what a rig
    reports (the state record: encoder angle and its rate, the servo target the host sent)."""
    _, info = env.reset(seed=seed, options={"start": "rest"})  # a rig starts as it is, settled
    state = info["state"]
    recording = Recording(excitation.actions(), float(state.servo_target_rad), float(state.pendulum_angle_rad))
    for action in recording.actions:
        _, _, _, _, info = env.step(action)
        recording.pendulum_rad.append(float(info["state"].pendulum_angle_rad))
        recording.pendulum_velocity_rad_s.append(float(info["state"].pendulum_velocity_rad_s))
    return recording


def angle_error_rad2(simulated: np.ndarray, recorded: np.ndarray) -> float:
    """Mean of 2 - 2 cos(difference): the squared angle error, free of the 2 pi wrap."""
    return float(np.mean(2.0 - 2.0 * np.cos(np.asarray(simulated) - np.asarray(recorded))))
