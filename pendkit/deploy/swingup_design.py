"""The kit's classical controllers designed for the device: the energy swing-up with its LQR hand-over, and
the minimum-time swing-up (the plan from rest, its time-varying gains, the energy law as the fallback).

Designed as the host designs them (`pendkit.control`), with the device's delays in place of the
network's (`pendkit.timing.device_command_delay_s`: a target chosen on an acting tick waits for the servo's
next PWM frame), and the device's estimate is of the present, so nothing else waits.
"""

from __future__ import annotations

import math

import control
import numpy as np

from pendkit.control.lqr import LqrBalancer, LqrWeights
from pendkit.control.model import FurutaModel
from pendkit.control.swingup import SwingUpConfig
from pendkit.control.tracking import TRACKING_WEIGHTS, time_varying_lqr
from pendkit.control.trajopt import StepModel, SwingUpLimits, fastest_bang_bang, initial_state
from pendkit.deploy.controllers import controller_named
from pendkit.device.swingup_blob import SwingUpBlob
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.timing import device_command_delay_s

# The pendulum filter's process noise: what the gravity-only prediction leaves out (the arm's push on the
# pivot reaches about 30 rad/s^2 while pumping); the measurement noise is the encoder's quantisation.
UNMODELLED_ACCELERATION_RAD_S2 = 30.0
REST_ANGLE_RAD, REST_VELOCITY_RAD_S = 0.1, 0.5  # a plan from rest is followed only from (near) rest
SETTLE_STEPS, WARMUP_STEPS, DRIFT_RAD = 30, 3, 0.15  # as pendkit.control.tracking.TrajectoryController


def pendulum_filter_gains(params: RigParams) -> tuple[float, float]:
    """Steady-state Kalman gains (angle, rate) of a constant-rate model at the acting tick (python-control)."""
    dt = params.acting_period_ms / 1000.0
    a = np.array([[1.0, dt], [0.0, 1.0]])
    g = np.array([[dt * dt / 2], [dt]])
    c = np.array([[1.0, 0.0]])
    quantum = 2 * math.pi / params.encoder_counts
    _, prior, _ = control.dlqe(a, g, c, np.array([[UNMODELLED_ACCELERATION_RAD_S2 ** 2]]),
                               np.array([[quantum ** 2 / 12]]))
    prior = np.asarray(prior)
    gain = prior @ c.T / (c @ prior @ c.T)[0, 0]
    return float(gain[0, 0]), float(gain[1, 0])


def _gains(given) -> tuple[float, float]:
    try:
        angle_gain, rate_gain = (float(g) for g in np.asarray(given, dtype=float).reshape(-1))
    except (TypeError, ValueError):
        raise ConfigError(f"observer gains must be two numbers (angle, rate), got {given!r}") from None
    if not (math.isfinite(angle_gain) and math.isfinite(rate_gain)):
        raise ConfigError(f"observer gains must be finite, got {given!r}")
    return angle_gain, rate_gain


def model_scalars(model: FurutaModel) -> dict[str, float]:
    """What the device's estimate predicts with, per unit of the inertia each acts on."""
    arm, pendulum = model.arm_inertia_kg_m2, model.pendulum_inertia_kg_m2
    return {"servo_kp_per_inertia": model.servo_kp_n_m_per_rad / arm,
            "servo_kv_per_inertia": model.servo_kv_n_m_s_per_rad / arm,
            "arm_damping_per_inertia": model.arm_damping_n_m_s_per_rad / arm,
            "stall_per_inertia": model.servo_stall_torque_n_m / arm,
            "coupling_per_inertia": model.coupling_kg_m2 / pendulum,
            "pendulum_damping_per_inertia": model.pendulum_damping_n_m_s_per_rad / pendulum}


def design_swing_up(params: RigParams | None = None, controller: str = "energy",
                    config: SwingUpConfig | None = None, weights: LqrWeights | None = None,
                    limits: SwingUpLimits | None = None,
                    observer_gains: tuple[float, float] | None = None) -> SwingUpBlob:
    """The device's swing-up for a rig by the controller's name (`pendkit.deploy.controllers`: "energy",
    pump and catch with LQR; "trajopt", the fastest plan from rest first, ...). `observer_gains` (angle,
    rate) replaces the pendulum filter's designed gains (lab 10)."""
    return controller_named(controller).design(params or RigParams(), config=config, weights=weights,
                                               limits=limits, observer_gains=observer_gains)


def swing_up_blob(params: RigParams, config: SwingUpConfig | None = None, weights: LqrWeights | None = None,
                  observer_gains: tuple[float, float] | None = None, catch_gain=None) -> SwingUpBlob:
    """The device's energy swing-up for a rig, caught by the LQR of `weights` (or by `catch_gain(balancer)`, a
    state feedback on the same five states), its pendulum filter designed for the rig unless `observer_gains`."""
    config = config or SwingUpConfig()
    if config.phase_lead_rad not in (0, 0.0):
        raise ConfigError("the device's swing-up has no phase lead (it reads the encoder itself): use 0")
    delay_s, period_s = device_command_delay_s(params), params.control_step_ms / 1000.0
    balancer = LqrBalancer(params, weights, period_s=period_s, delay_s=delay_s, internal_filter=True)
    model = balancer.model
    angle_gain, rate_gain = pendulum_filter_gains(params) if observer_gains is None else _gains(observer_gains)
    scalars = {"period_s": period_s, "acting_period_s": params.acting_period_ms / 1000.0,
               "observer_angle_gain": angle_gain, "observer_rate_gain": rate_gain,
               "natural_frequency_rad_s": model.natural_frequency_rad_s,
               "energy_gain": config.energy_gain, "swing_rate_rad_s": config.swing_rate_rad_s,
               "centring_per_s": config.centring_per_s, "arm_limit_rad": config.arm_limit_rad,
               "target_energy": config.target_energy, "catch_angle_rad": config.catch_angle_rad,
               "catch_velocity_rad_s": config.catch_velocity_rad_s, "fall_angle_rad": config.fall_angle_rad,
               "filter_coefficient": balancer.filter_coefficient, "servo_range_rad": params.servo_range_rad,
               "rest_angle_rad": REST_ANGLE_RAD, "rest_velocity_rad_s": REST_VELOCITY_RAD_S, "drift_rad": DRIFT_RAD,
               **model_scalars(model)}
    gain = balancer.gain if catch_gain is None else catch_gain(balancer)
    return SwingUpBlob(scalars, np.asarray(gain, dtype=float).reshape(-1), np.zeros(5))


def with_plan_from_rest(blob: SwingUpBlob, params: RigParams, limits: SwingUpLimits | None = None) -> SwingUpBlob:
    """`blob` with the fastest plan from rest and its time-varying gains; where no plan reaches upright within
    40 steps, the blob has none and pumps energy from the start (as the laptop's TrajectoryController)."""
    step_model = StepModel(FurutaModel.from_rig(params), params.control_step_ms / 1000.0,
                           device_command_delay_s(params))
    plan = fastest_bang_bang(step_model, initial_state(), limits or SwingUpLimits(), 40, 5)
    if plan is None:
        return blob
    gains, settle_gain = time_varying_lqr(step_model, plan, TRACKING_WEIGHTS)
    blob.plan_targets = plan.targets_rad.astype(np.float32)
    blob.plan_states = plan.states[:-1].astype(np.float32)
    blob.plan_gains = gains[:, 0, :].astype(np.float32)
    blob.settle_gain = settle_gain.reshape(-1).astype(np.float32)
    blob.settle_steps, blob.warmup_steps = SETTLE_STEPS, WARMUP_STEPS
    return blob
