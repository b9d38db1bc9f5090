"""Encoder readings of a freely swinging twin at a chosen sampling period (for the sensing labs)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from pendkit.encoder import firmware_velocity, rad_to_counts
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.sim.model import fresh_model


@dataclass(frozen=True)
class SwingReadings:
    """What an MCU sampling every `period_ms` would read, beside the twin's true velocity."""

    period_ms: float
    times_ms: np.ndarray
    raw_counts: np.ndarray
    true_velocity_rev_s: np.ndarray


def free_swing_readings(period_ms: float = 25.0, duration_s: float = 4.0, start_velocity_rad_s: float = 14.0,
                        offset_counts: int = 0, params: RigParams | None = None) -> SwingReadings:
    """Spin the pendulum (arm held) from hanging at `start_velocity_rad_s` and sample its encoder.

    14 rad/s carries it over the top a few times before damping lets it settle into swinging.
    """
    params = params or RigParams()
    steps_per_sample = period_ms / params.physics_step_ms
    if period_ms <= 0 or abs(steps_per_sample - round(steps_per_sample)) > 1e-9:
        raise ConfigError(f"period_ms must be a positive multiple of physics_step_ms={params.physics_step_ms}, "
                          f"got {period_ms}")
    model = fresh_model(params, lock_arm=True)
    data = mujoco.MjData(model)
    data.qvel[0] = start_velocity_rad_s
    mujoco.mj_forward(model, data)
    samples = int(duration_s * 1000 / period_ms) + 1
    angles, velocities = np.empty(samples), np.empty(samples)
    for k in range(samples):
        angles[k], velocities[k] = data.qpos[0], data.qvel[0]
        mujoco.mj_step(model, data, round(steps_per_sample))
    return SwingReadings(period_ms, np.arange(samples) * float(period_ms),
                         rad_to_counts(angles, offset_counts, params.encoder_counts),
                         velocities / (2 * math.pi))


def firmware_estimate_error_rev_s(period_ms: float, duration_s: float = 4.0, window: int = 4,
                                  start_velocity_rad_s: float = 14.0) -> float:
    """RMS error of the firmware's estimate against the true velocity at one sampling period.

    The mean of the last `window` differences telescopes to (p_k - p_(k-window)) / (window * period):
    it describes the motion about window/2 periods ago. It is compared with the truth at the reading's
    own time, so that lag counts as error, as it does for a controller.
    """
    readings = free_swing_readings(period_ms, duration_s, start_velocity_rad_s)
    estimate, _ = firmware_velocity(readings.raw_counts, readings.times_ms, window)
    settled = slice(window, None)  # skip the buffer's start-up zeros
    return float(np.sqrt(np.mean((estimate[settled] - readings.true_velocity_rev_s[settled]) ** 2)))


@dataclass(frozen=True)
class ServoStepReadings:
    times_s: np.ndarray
    commanded_rad: np.ndarray
    arm_rad: np.ndarray


def servo_step_readings(steps_rad=(0.6, -0.6, 0.2), hold_s: float = 0.6,
                        params: RigParams | None = None, start_rad: float = 0.0) -> ServoStepReadings:
    """Step the servo's target through `steps_rad` (holding each for `hold_s`) with the pendulum hanging and
    the arm first at rest at `start_rad`, and record the commanded and the true arm angle every physics
    step (5 ms)."""
    params = params or RigParams()
    model = fresh_model(params)
    data = mujoco.MjData(model)
    data.qpos[0] = data.act[0] = start_rad
    mujoco.mj_forward(model, data)
    per_step = round(hold_s * 1000 / params.physics_step_ms)
    times, commands, arms = [], [], []
    for target in (start_rad, *steps_rad):
        data.act[0] = target
        for _ in range(per_step):
            times.append(data.time)
            commands.append(target)
            arms.append(data.qpos[0])
            mujoco.mj_step(model, data)
    return ServoStepReadings(np.array(times), np.array(commands), np.array(arms))
