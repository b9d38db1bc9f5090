"""A state observer for a rig whose sensing is delayed and partial (the realistic twin, the real rig).

It predicts with the full nonlinear model (servo saturation included) over each control step, the
new target reaching the servo after the actuation delay, and corrects with the one thing the encoder
measures, the pendulum angle, compared with the prediction *at the reading's own time*. The gain is a
steady-state Kalman gain of the linear model about upright (python-control's `dlqe`), used everywhere:
far from upright the correction is rougher, but the nonlinear prediction carries the estimate.
"""

from __future__ import annotations

import math

import control
import numpy as np

from pendkit.backend_contract import RigState
from pendkit.control.model import FurutaModel

SUBSTEP_S = 0.005


class DelayedAngleObserver:
    """Estimate of [arm angle, pendulum angle from the bottom, their rates]."""

    def __init__(self, model: FurutaModel, period_s: float, actuation_delay_s: float, reading_latency_s: float,
                 process_std: tuple[float, float, float, float] = (1e-3, 1e-3, 0.05, 0.05),
                 measurement_std_rad: float = (2 * math.pi / 1024) / math.sqrt(12)) -> None:
        self.model, self.period_s = model, period_s
        self.actuation_delay_s, self.reading_latency_s = actuation_delay_s, reading_latency_s
        self.gain = self._kalman_gain(process_std, measurement_std_rad)
        self.estimate = np.zeros(4)
        self.target_in_force_rad = 0.0
        self.ramp_in_force_rad_s = 0.0
        self._history: list[tuple[float, float]] = []  # (seconds before now, predicted pendulum angle)
        self.last_innovation_rad = 0.0  # the newest reading less the model's prediction of it

    def _kalman_gain(self, process_std, measurement_std_rad: float) -> np.ndarray:
        linear = control.c2d(self.model.linearise("upright"), self.period_s, method="zoh")
        c = np.array([[0.0, 1.0, 0.0, 0.0]])
        _, prior, _ = control.dlqe(linear.A, np.eye(4), c, np.diag(process_std) ** 2,
                                   np.array([[measurement_std_rad**2]]))
        prior = np.asarray(prior)
        return (prior @ c.T / (c @ prior @ c.T)[0, 0])[:, 0]

    def reset(self, state: RigState) -> None:
        self.estimate = np.array([state.arm_angle_rad, state.pendulum_angle_rad, state.arm_velocity_rad_s,
                                  state.pendulum_velocity_rad_s])
        self.target_in_force_rad = state.servo_target_rad
        self.ramp_in_force_rad_s = 0.0
        self._history = []

    def correct(self, state: RigState) -> np.ndarray:
        """Fold in the newest reading; return the estimate."""
        age_s = state.observation_age_s + self.reading_latency_s
        predicted = self._predicted_angle_at(age_s)
        innovation = (state.pendulum_angle_rad - predicted + math.pi) % (2 * math.pi) - math.pi
        self.estimate = self.estimate + self.gain * innovation
        self.last_innovation_rad = innovation
        return self.estimate

    def _predicted_angle_at(self, age_s: float) -> float:
        if not self._history:
            return self.estimate[1]
        return min(self._history, key=lambda item: abs(item[0] - age_s))[1]

    def predict(self, new_target_rad: float) -> None:
        """Advance one control step: the old target acts until the new one arrives."""
        self.predict_ramp(new_target_rad, 0.0)

    def predict_ramp(self, new_target_rad: float | None, ramp_rad_s: float, limit_rad: float = math.inf) -> None:
        """Advance one control step in which the target, once the command arrives, jumps to
        `new_target_rad` (None: stays where it is) and moves at `ramp_rad_s` (a discrete action's
        increments on every acting tick), held within +-`limit_rad` (the arm's range). Before the arrival
        the previous ramp continues."""
        steps = max(1, round(self.period_s / SUBSTEP_S))
        switch = round(self.actuation_delay_s / SUBSTEP_S)
        x = self.estimate
        angles = []
        target, ramp = self.target_in_force_rad, self.ramp_in_force_rad_s
        for k in range(steps):
            if k == switch:
                target, ramp = (target if new_target_rad is None else new_target_rad), ramp_rad_s
            x = self._rk4(x, target, SUBSTEP_S)
            target = min(max(target + ramp * SUBSTEP_S, -limit_rad), limit_rad)
            angles.append(x[1])
        if switch >= steps:  # arrives at the step's very end: in force from the next step on
            target, ramp = (target if new_target_rad is None else new_target_rad), ramp_rad_s
        self.estimate = x
        self.target_in_force_rad, self.ramp_in_force_rad_s = target, ramp
        self._history = [((steps - 1 - k) * SUBSTEP_S, angle) for k, angle in enumerate(angles)]

    def _rk4(self, x: np.ndarray, target: float, dt: float) -> np.ndarray:
        def derivative(s: np.ndarray) -> np.ndarray:
            accel = self.model.accelerations(s, target)
            return np.array([s[2], s[3], accel[0], accel[1]])

        k1 = derivative(x)
        k2 = derivative(x + dt / 2 * k1)
        k3 = derivative(x + dt / 2 * k2)
        k4 = derivative(x + dt * k3)
        return x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def as_state(self, state: RigState) -> RigState:
        """`state` with the estimated angles and rates in place of the measured ones."""
        x = self.estimate
        return state._replace(arm_angle_rad=float(x[0]), pendulum_angle_rad=float(x[1]) % (2 * math.pi),
                              arm_velocity_rad_s=float(x[2]), pendulum_velocity_rad_s=float(x[3]))
