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

from pendkit.adapt.replay import DeviceTrace, trace_from_log
from pendkit.encoder import wrapped_rad
from pendkit.telemetry.log import read_log

CENTRE = 0.0
# (half-period in steps, amplitude as a fraction of the arm's half range), one per episode, cycled
EPISODES = ((2, 0.9), (6, 0.3), (3, 0.9), (5, 0.45), (2, 0.8), (8, 0.4), (3, 0.7), (12, 0.35), (4, 0.5),
            (7, 0.3))
# the servo's loop: steps of 5-11 degrees, within a step or so of the servo's speed limit, every 1-2 steps.
# Through the big jumps above the loop's stiffness hardly shows (on one rig a full-torque error read anywhere
# from 1 to 3.6 degrees matched within 8%); after these steps the stiffness and damping set how the pendulum
# twitches (the same spread then costs 10-95% more). Too small to swing the pendulum freely: no free swing.
# `pendkit adapt` leaves them out by default: with them (the servo refined over them) its device plans solved
# no more hidden rigs, though the loop was read closer (docs/results/transfer.md).
LOOP_EPISODES = ((1, 0.06), (2, 0.1), (1, 0.12))
LOOP_DRIVE_STEPS, LOOP_FREE_STEPS = 40, 20
# the free swing after the jumps: 90 steps (5.4 s) for a recording made by hand (lab 09's notebook is measured
# with it); `pendkit adapt`, whose rig time is the class's scarcest, takes 78 (about four of the pendulum's
# periods, its three episodes within 20 s of rig time): on the six hidden-rig stand-ins 78 read the servo's speed
# and the pendulum as closely as 90, and an underdamped servo loop's damping as closely by adapt's own rule (the
# closest of three searches): benchmarks/studies/adapt_free_swing.py and adapt_loop_damping.py,
# docs/results/adapt-time.md
FREE_STEPS = 90
ADAPT_FREE_STEPS = 78
SETTLE_STEPS = 8  # after the last jump back to the centre, before the swing counts as free
# at rest: the encoder stays within 3 counts over REST_STEPS steps (half a period; a count's flicker allowed)
REST_SPREAD_RAD = 3 * 2 * np.pi / 1024
REST_STEPS = 8
# the stream an excitation asks of the device: a reading every 10 ms times each target's effect within a
# physics tick or two (every 25 ms, the replayed twin's timing alone misses the rig by 0.01-0.05 rad^2)
EXCITATION_STREAM = {"streaming_period_ms": 10.0, "velocity_mean_window": 2}
REST_LIMIT_STEPS = 2000  # 2 minutes: a pendulum still swinging then is not one a recording can start from


@dataclass(frozen=True)
class Excitation:
    """One episode's schedule: `drive_steps` of a square wave of the target (+-`amplitude_unit` of the arm's
    half range, `half_period_steps`), then the target at the centre for `free_steps`."""

    half_period_steps: int
    amplitude_unit: float
    drive_steps: int = 12
    free_steps: int = FREE_STEPS

    def actions(self) -> list[float]:
        drive = [self.amplitude_unit if (k // self.half_period_steps) % 2 == 0 else -self.amplitude_unit
                 for k in range(self.drive_steps)]
        return drive + [CENTRE] * self.free_steps

    @staticmethod
    def env_kwargs() -> dict:
        """How an env must be made to take these actions as targets: continuous, unfiltered."""
        return {"action_mode": "continuous", "filter_coefficient": 0.0}


def schedule(episodes: int, loop_episodes: int = 0, free_steps: int = FREE_STEPS) -> list[Excitation]:
    """`episodes` of big jumps and a free swing of `free_steps`, then `loop_episodes` of small quick steps
    (`LOOP_EPISODES`)."""
    return ([Excitation(*EPISODES[k % len(EPISODES)], free_steps=free_steps) for k in range(episodes)]
            + [Excitation(*LOOP_EPISODES[k % len(LOOP_EPISODES)], LOOP_DRIVE_STEPS, LOOP_FREE_STEPS)
               for k in range(loop_episodes)])


def free_from(actions: list[float]) -> int | None:
    """The first step of the free swing: `SETTLE_STEPS` after the target last moved (None if it never rests)."""
    moves = [k for k in range(1, len(actions)) if actions[k] != actions[k - 1]]
    first = (moves[-1] if moves else 0) + SETTLE_STEPS
    return first if first < len(actions) and actions[-1] == CENTRE else None


@dataclass
class Recording:
    """What one excitation episode gave: the targets sent (arm half-range units), the servo target the host
    knows at the start, and per step the pendulum's encoder angle (rad from the bottom) and its rate (rad/s);
    `rest_steps`: the steps spent holding the arm until the pendulum hung still (rig time too); `device`: every
    reading on the device's clock, when the env logged its messages (`pendkit.adapt.replay`)."""

    actions: list[float]
    start_servo_target_rad: float
    start_pendulum_rad: float
    pendulum_rad: list[float] = field(default_factory=list)
    pendulum_velocity_rad_s: list[float] = field(default_factory=list)
    rest_steps: int = 0
    device: DeviceTrace | None = None

    @property
    def rig_steps(self) -> int:
        return self.rest_steps + len(self.actions)

    def as_dict(self) -> dict:
        return {"actions": self.actions, "start_servo_target_rad": self.start_servo_target_rad,
                "start_pendulum_rad": self.start_pendulum_rad, "pendulum_rad": self.pendulum_rad,
                "pendulum_velocity_rad_s": self.pendulum_velocity_rad_s, "rest_steps": self.rest_steps,
                "device": None if self.device is None else self.device.as_dict()}

    @classmethod
    def from_dict(cls, record: dict) -> Recording:
        device = record.get("device")
        return cls(**{**record, "device": None if device is None else DeviceTrace.from_dict(device)})


class NotAtRest(RuntimeError):
    """The pendulum kept swinging: an excitation episode must start from rest, as the twin's does."""


def hold_until_at_rest(env, state) -> tuple[object, int]:
    """Hold the servo at the centre until the pendulum hangs still (a rig starts as the last run left it,
    perhaps still swinging; the twin matched to it starts from rest). Returns the state it rests in and the
    steps it took."""
    angles = [state.pendulum_angle_rad]
    # not `run_episode`: holding may take longer than the env's episode (its truncation is not an end here)
    for _ in range(REST_LIMIT_STEPS):
        recent = wrapped_rad(np.asarray(angles[-REST_STEPS:]) - angles[-1])
        if len(angles) >= REST_STEPS and np.ptp(recent) <= REST_SPREAD_RAD:
            return state, len(angles) - 1
        _, _, _, _, info = env.step(np.array([CENTRE], dtype=np.float32))
        state = info["state"]
        angles.append(state.pendulum_angle_rad)
    raise NotAtRest(f"the pendulum still swings ({np.degrees(np.ptp(recent)):.1f} deg in the last {REST_STEPS} "
                    f"steps) after {REST_LIMIT_STEPS} steps with the arm held at the centre: stop it by hand "
                    "(or check the encoder) before recording")


def record(env, excitation: Excitation, seed: int = 0) -> Recording:
    """Run one excitation episode on `env` (made with `Excitation.env_kwargs()`: twin or rig), from rest,
    reading only what a rig reports (the state record: encoder angle and its rate, the servo target sent;
    with the env's `log_dir`, every reading on the device's clock too)."""
    _, info = env.reset(seed=seed, options={"start": "rest"})
    state, rest_steps = hold_until_at_rest(env, info["state"])
    recording = Recording(excitation.actions(), float(state.servo_target_rad), float(state.pendulum_angle_rad),
                          rest_steps=rest_steps)
    log = getattr(env.unwrapped.backend, "episode_log", None)
    logged_before = logged_count(log)
    for action in recording.actions:  # not `run_episode`: continues the held episode past the env's limit
        _, _, _, _, info = env.step(np.array([action], dtype=np.float32))
        recording.pendulum_rad.append(float(info["state"].pendulum_angle_rad))
        recording.pendulum_velocity_rad_s.append(float(info["state"].pendulum_velocity_rad_s))
    if log is not None:
        log.flush()
        recording.device = trace_from_log(read_log(log.path), logged_before, env.unwrapped.params.encoder_counts)
    return recording


def rest_offset_counts(recordings: list[Recording], counts: int) -> int:
    """What the encoder read, in counts, with the pendulum hanging still before each episode (median over
    the episodes): a hanging pendulum is plumb, so this is the calibration's residual error, which a
    balance designed for true upright would otherwise lean against."""
    readings = [wrapped_rad(r.start_pendulum_rad) * counts / (2 * np.pi) for r in recordings]
    return int(np.round(np.median(readings))) if readings else 0


def logged_count(log) -> int:
    if log is None:
        return 0
    log.flush()
    return len(read_log(log.path))
