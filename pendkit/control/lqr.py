"""LQR balance about upright: python-control's `dlqr` on the model discretised at the control period,
with the env's action filter as an extra state. A policy object for the env's continuous mode."""

from __future__ import annotations

import math
from dataclasses import dataclass

import control
import numpy as np

from pendkit.control.model import FurutaModel, filtered_model
from pendkit.errors import ConfigError
from pendkit.features import angle_from_upright_rad
from pendkit.rig import RigParams
from pendkit.state import RigState


@dataclass(frozen=True)
class LqrWeights:
    """Diagonal state weights (per rad^2 or (rad/s)^2) and the input weight (per rad^2 of raw target).

    The defaults favour the pendulum angle, keep the arm near the centre, and charge enough for the
    target that the filtered command stays inside the servo's range after small pushes.
    """

    arm_angle: float = 2.0
    pendulum_angle: float = 40.0
    arm_velocity: float = 0.05
    pendulum_velocity: float = 0.5
    filtered_target: float = 0.0
    action: float = 3.0

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if not math.isfinite(value) or value < 0:
                raise ConfigError(f"LQR weight {name} must be finite and >= 0, got {value}")
        if self.action <= 0:
            raise ConfigError(f"LQR weight action must be > 0 (R must be positive definite), got {self.action}")

    def q_matrix(self) -> np.ndarray:
        return np.diag([self.arm_angle, self.pendulum_angle, self.arm_velocity, self.pendulum_velocity,
                        self.filtered_target])


def lqr_gain(system: control.StateSpace, q: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(K, closed-loop poles) of a discrete system, with clear errors for impossible designs."""
    a, b = np.asarray(system.A), np.asarray(system.B)
    q, r = np.atleast_2d(q), np.atleast_2d(r)
    if q.shape != a.shape or r.shape != (b.shape[1], b.shape[1]):
        raise ConfigError(f"Q must be {a.shape} and R {(b.shape[1],) * 2}, got {q.shape} and {r.shape}")
    if not np.allclose(q, q.T) or np.min(np.linalg.eigvalsh(q)) < -1e-12:
        raise ConfigError("Q must be symmetric positive semidefinite (no negative weights)")
    if np.min(np.linalg.eigvalsh((r + r.T) / 2)) <= 0:
        raise ConfigError("R must be positive definite (a positive weight on the action)")
    _check_stabilisable(a, b)
    try:
        gain, _, poles = control.dlqr(a, b, q, r)
    except Exception as error:  # python-control reports unsolvable Riccati equations in several ways
        raise ConfigError(f"no LQR solution for these weights: {error}") from error
    return np.asarray(gain), np.asarray(poles)


def _check_stabilisable(a: np.ndarray, b: np.ndarray) -> None:
    """PBH test: every mode on or outside the unit circle must be reachable from the input."""
    n = a.shape[0]
    for eigenvalue in np.linalg.eigvals(a):
        if abs(eigenvalue) >= 1 - 1e-9:
            rank = np.linalg.matrix_rank(np.hstack([a - eigenvalue * np.eye(n), b]), tol=1e-9)
            if rank < n:
                raise ConfigError(f"the model is not stabilisable: the mode at {eigenvalue:.3f} cannot be "
                                  "moved by the input")


@dataclass(frozen=True)
class ObserverNoise:
    """Kalman filter tuning: how much the model is trusted (process) against the encoder (measurement).

    The measurement default is the encoder's quantisation noise, one count / sqrt(12).
    """

    angle_rad: float = 1e-3
    velocity_rad_s: float = 0.05
    measurement_rad: float = (2 * math.pi / 1024) / math.sqrt(12)

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"ObserverNoise.{name} must be > 0, got {value}")


class LqrBalancer:
    """Balance the pendulum upright through the env's continuous action (a normalised servo target).

    The design model is the linearisation about upright, discretised at the control period, with the
    env's action filter and the loop's delay (`delay_s`: from the reading to the servo seeing the new
    target) as part of it. `estimator="measured"` feeds back the observed state as it is (ideal sensing);
    `"observer"` runs a steady-state Kalman filter on the measured pendulum angle, predicting with the
    model and the targets sent, so velocities need not come from the firmware's lagging estimate.

    With `internal_filter=True` the filter runs in the controller and the env's must be off
    (`filter_coefficient=0`): the LQR's targets are smoothed as designed, while another controller
    sharing the env (the swing-up) can move the target freely.

    Call `reset(state)` at the start of an episode, then `action(state)` every step.
    """

    def __init__(self, params: RigParams | None = None, weights: LqrWeights | None = None,
                 period_s: float | None = None, filter_coefficient: float | None = None, delay_s: float = 0.0,
                 estimator: str = "measured", noise: ObserverNoise | None = None,
                 internal_filter: bool = False) -> None:
        if estimator not in ("measured", "observer"):
            raise ConfigError(f"estimator must be 'measured' or 'observer', got {estimator!r}")
        self.params = params or RigParams()
        self.weights = weights or LqrWeights()
        self.period_s = period_s if period_s is not None else self.params.control_step_ms / 1000
        self.filter_coefficient = (self.params.filter_coefficient if filter_coefficient is None
                                   else filter_coefficient)
        self.delay_s, self.estimator, self.internal_filter = delay_s, estimator, internal_filter
        self.model = FurutaModel.from_rig(self.params)
        self.system = filtered_model(self.model.linearise("upright"), self.period_s, self.filter_coefficient,
                                     delay_s)
        self.gain, self.closed_loop_poles = lqr_gain(self.system, self.weights.q_matrix(),
                                                     np.array([[self.weights.action]]))
        self.observer_gain = self._kalman_gain(noise or ObserverNoise()) if estimator == "observer" else None
        self._filtered_rad = 0.0
        self._estimate = np.zeros(4)

    @classmethod
    def for_env(cls, env, **kwargs) -> LqrBalancer:
        """A balancer designed for this env's step, filter and expected loop delay."""
        base = env.unwrapped
        delay, estimator = expected_loop_delay_s(base), "measured"
        if base.backend.fidelity.mcu_pipeline:
            estimator = "observer"
        kwargs.setdefault("estimator", estimator)
        internal = base.filter_coefficient == 0  # no filter in the env: smooth our own targets
        design_filter = base.params.filter_coefficient if internal else base.filter_coefficient
        return cls(base.params, period_s=base.dt, filter_coefficient=design_filter, delay_s=delay,
                   internal_filter=internal, **kwargs)

    def _kalman_gain(self, noise: ObserverNoise) -> np.ndarray:
        a = np.asarray(self.system.A)[:4, :4]
        c = np.array([[0.0, 1.0, 0.0, 0.0]])  # the encoder measures the pendulum angle only
        process = np.diag([noise.angle_rad, noise.angle_rad, noise.velocity_rad_s, noise.velocity_rad_s]) ** 2
        _, prior, _ = control.dlqe(a, np.eye(4), c, process, np.array([[noise.measurement_rad**2]]))
        prior = np.asarray(prior)
        return prior @ c.T / (c @ prior @ c.T)[0, 0]  # current-estimate form: correct, then act

    def reset(self, state: RigState) -> None:
        self._filtered_rad = state.servo_target_rad
        self._estimate = self._measured(state)

    def _measured(self, state: RigState) -> np.ndarray:
        return np.array([state.arm_angle_rad, angle_from_upright_rad(state), state.arm_velocity_rad_s,
                         state.pendulum_velocity_rad_s])

    def state_estimate(self, state: RigState) -> np.ndarray:
        """[arm angle, pendulum angle from upright, their rates] the controller acts on."""
        if self.observer_gain is None:
            return self._measured(state)
        innovation = angle_from_upright_rad(state) - self._estimate[1]
        innovation = (innovation + math.pi) % (2 * math.pi) - math.pi
        return self._estimate + self.observer_gain[:, 0] * innovation

    def action(self, state: RigState) -> np.ndarray:
        """The env action in [-1, 1] (clipped); the filter and the estimate advance as the env will."""
        estimate = self.state_estimate(state)
        z = np.append(estimate, self._filtered_rad)
        unit = float(np.clip(-(self.gain @ z)[0] / self.params.servo_range_rad, -1.0, 1.0))
        applied_rad = unit * self.params.servo_range_rad
        if self.observer_gain is not None:
            predicted = np.asarray(self.system.A) @ z + np.asarray(self.system.B)[:, 0] * applied_rad
            self._estimate = predicted[:4]
        c = self.filter_coefficient
        self._filtered_rad = c * self._filtered_rad + (1 - c) * applied_rad
        if self.internal_filter:
            unit = self._filtered_rad / self.params.servo_range_rad
        return np.array([unit], dtype=np.float32)

    def __call__(self, observation, state: RigState) -> np.ndarray:
        return self.action(state)


def expected_loop_delay_s(env) -> float:
    """Mean time from an encoder reading to the servo acting on the answer, for a twin env.

    Ideal: none. Paper-delayed: the 0-2 substeps after the observation (mean one). Realistic: half a
    streaming period plus one latency (the reading's age), then a latency, half an acting tick and half
    a PWM frame (the command's way to the servo).
    """
    base = env.unwrapped
    fidelity, p = base.backend.fidelity, base.params
    if not fidelity.mcu_pipeline:
        return fidelity.post_observation_substeps_max / 2 * p.physics_step_ms / 1000
    latency = fidelity.latency
    median_ms = (np.median(latency.samples_ms) if latency.samples_ms
                 else latency.floor_ms + latency.median_ms)
    delay_ms = p.streaming_period_ms / 2 + 2 * median_ms + p.acting_period_ms / 2 + p.pwm_period_ms / 2
    return float(min(delay_ms / 1000, 0.9 * base.dt))
