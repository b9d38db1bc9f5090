"""Excitation episodes: open-loop schedules of the servo's target that make a rig's parameters visible in
the pendulum's encoder (a hobby servo reports nothing of its arm).

Each episode starts from rest and sends the target itself (continuous actions, no filter), jumping it
between +A and -A every few steps for 12 steps, then back to the centre, and lets the pendulum swing freely
for 90 steps (over 4 of its periods). A jump of a whole 70-140 degrees takes the servo 0.2-0.8 s at its rated
speed, so how long the arm ramps (the servo's speed), how it stops (its torque and loop), when it starts (the
latency) and the free swing (the pendulum's frequency and damping) all shape what the encoder records.
The discrete actions would not do: their fastest ramp (about 4 rad/s) is slower than most servos, which
then never show their speed. Half-periods and amplitudes vary from episode to episode and stay off the
pendulum's own (about 10 steps), so the pendulum is pushed, not pumped over the top.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

CENTRE = 0.0
# (half-period in steps, amplitude as a fraction of the arm's half range), one per episode, cycled
EPISODES = ((2, 0.9), (6, 0.3), (3, 0.9), (5, 0.45), (2, 0.8), (8, 0.4), (3, 0.7), (12, 0.35), (4, 0.5),
            (7, 0.3))
SETTLE_STEPS = 8  # after the last jump back to the centre, before the swing counts as free


@dataclass(frozen=True)
class Excitation:
    """One episode's schedule: `drive_steps` of a square wave of the target (+-`amplitude_unit` of the arm's
    half range, `half_period_steps`), then the target at the centre for `free_steps`."""

    half_period_steps: int
    amplitude_unit: float
    drive_steps: int = 12
    free_steps: int = 90

    def actions(self) -> list[float]:
        drive = [self.amplitude_unit if (k // self.half_period_steps) % 2 == 0 else -self.amplitude_unit
                 for k in range(self.drive_steps)]
        return drive + [CENTRE] * self.free_steps

    @staticmethod
    def env_kwargs() -> dict:
        """How an env must be made to take these actions as targets: continuous, unfiltered."""
        return {"action_mode": "continuous", "filter_coefficient": 0.0}


def schedule(episodes: int) -> list[Excitation]:
    return [Excitation(*EPISODES[k % len(EPISODES)]) for k in range(episodes)]


def free_from(actions: list[float]) -> int | None:
    """The first step of the free swing: `SETTLE_STEPS` after the target last moved (None if it never rests)."""
    moves = [k for k in range(1, len(actions)) if actions[k] != actions[k - 1]]
    first = (moves[-1] if moves else 0) + SETTLE_STEPS
    return first if first < len(actions) and actions[-1] == CENTRE else None


@dataclass
class Recording:
    """What one excitation episode gave: the targets sent (arm half-range units), the servo target the host
    knows at the start, and per step the pendulum's encoder angle (rad from the bottom) and its rate (rad/s)."""

    actions: list[float]
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
    """Run one excitation episode on `env` (made with `Excitation.env_kwargs()`: twin or rig), reading only
    what a rig reports (the state record: encoder angle and its rate, the servo target the host sent)."""
    _, info = env.reset(seed=seed, options={"start": "rest"})  # a rig starts as it is, settled
    state = info["state"]
    recording = Recording(excitation.actions(), float(state.servo_target_rad), float(state.pendulum_angle_rad))
    for action in recording.actions:
        _, _, _, _, info = env.step(np.array([action], dtype=np.float32))
        recording.pendulum_rad.append(float(info["state"].pendulum_angle_rad))
        recording.pendulum_velocity_rad_s.append(float(info["state"].pendulum_velocity_rad_s))
    return recording


def angle_error_rad2(simulated: np.ndarray, recorded: np.ndarray) -> float:
    """Mean of 2 - 2 cos(difference): the squared angle error for small differences, free of the 2 pi wrap
    and smooth at half a turn (lab 09's students write the wrapped square instead)."""
    return float(np.mean(2.0 - 2.0 * np.cos(np.asarray(simulated) - np.asarray(recorded))))
