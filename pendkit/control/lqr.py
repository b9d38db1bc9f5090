"""LQR balance about upright: python-control's `dlqr` on the model discretised at the control period,
with the env's action filter as an extra state. A policy object for the env's continuous mode."""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np

from pendkit.backend_contract import RigState
from pendkit.checks import check_fields
from pendkit.control.model import FurutaModel, filtered_model
from pendkit.control.observer import DelayedAngleObserver
from pendkit.errors import ConfigError
from pendkit.features import angle_from_upright_rad
from pendkit.rig import RigParams


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
        check_fields(self, lambda weight: weight >= 0, ">= 0")
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


class LqrBalancer:
    """Balance the pendulum upright through the env's continuous action (a normalised servo target).

    The design model is the linearisation about upright, discretised at the control period, with the
    env's action filter and the delay from command to servo (`delay_s`) as part of it.
    `estimator="measured"` feeds back the observed state as it is (ideal sensing); `"observer"` feeds
    back a `DelayedAngleObserver`'s estimate (realistic sensing: a quantised, delayed angle and lagging
    rates). With `internal_filter=True` the filter runs in the controller and the env's must be off
    (`filter_coefficient=0`): the LQR's targets are smoothed as designed, while another controller
    sharing the env (the swing-up) can move the target freely.

    Call `reset(state)` at the start of an episode, then `action(state)` every step.
    """

    def __init__(self, params: RigParams | None = None, weights: LqrWeights | None = None,
                 period_s: float | None = None, filter_coefficient: float | None = None, delay_s: float = 0.0,
                 observer: DelayedAngleObserver | None = None, internal_filter: bool = False) -> None:
        self.params = params or RigParams()
        self.weights = weights or LqrWeights()
        self.period_s = period_s if period_s is not None else self.params.control_step_ms / 1000
        self.filter_coefficient = (self.params.filter_coefficient if filter_coefficient is None
                                   else filter_coefficient)
        self.delay_s, self.observer, self.internal_filter = delay_s, observer, internal_filter
        self.model = FurutaModel.from_rig(self.params)
        self.system = filtered_model(self.model.linearise("upright"), self.period_s, self.filter_coefficient,
                                     delay_s)
        self.gain, self.closed_loop_poles = lqr_gain(self.system, self.weights.q_matrix(),
                                                     np.array([[self.weights.action]]))
        self._filtered_rad = 0.0

    @classmethod
    def for_env(cls, env, weights: LqrWeights | None = None) -> LqrBalancer:
        """A balancer designed for this env's step, filter and delays; with an observer where the env's
        sensing is realistic."""
        base = env.unwrapped
        timing = base.timing
        internal = base.filter_coefficient == 0  # no filter in the env: smooth our own targets
        design_filter = base.params.filter_coefficient if internal else base.filter_coefficient
        observer = None
        if timing.firmware_readings:
            observer = DelayedAngleObserver(FurutaModel.from_rig(base.params), base.dt, timing.command_delay_s,
                                            timing.reading_delay_s)
        return cls(base.params, weights, period_s=base.dt, filter_coefficient=design_filter,
                   delay_s=timing.design_delay_s,
                   observer=observer, internal_filter=internal)

    def reset(self, state: RigState, keep_estimate: bool = False) -> None:
        """Start balancing from `state` (its servo_target_rad, within the servo's range, is the filter's state)."""
        limit = self.params.servo_range_rad
        self._filtered_rad = max(-limit, min(limit, state.servo_target_rad))
        if self.observer is not None and not keep_estimate:
            self.observer.reset(state)

    def estimate(self, state: RigState) -> RigState:
        """The state to act on: as measured, or the observer's estimate after folding in `state`."""
        if self.observer is None:
            return state
        self.observer.correct(state)
        return self.observer.as_state(state)

    def advance(self, target_in_force_rad: float) -> None:
        """Tell the observer which target the servo will be given for the coming step."""
        if self.observer is not None:
            self.observer.predict(target_in_force_rad)

    def control(self, estimate: RigState) -> float:
        """The env action in [-1, 1] for an estimated state; advances the filter as the env (or we) will."""
        z = np.array([estimate.arm_angle_rad, angle_from_upright_rad(estimate), estimate.arm_velocity_rad_s,
                      estimate.pendulum_velocity_rad_s, self._filtered_rad])
        unit = float(np.clip(-(self.gain @ z)[0] / self.params.servo_range_rad, -1.0, 1.0))
        c = self.filter_coefficient
        self._filtered_rad = c * self._filtered_rad + (1 - c) * unit * self.params.servo_range_rad
        return self._filtered_rad / self.params.servo_range_rad if self.internal_filter else unit

    @property
    def target_in_force_rad(self) -> float:
        """The target the servo holds after the last `control` (the filter's output)."""
        return self._filtered_rad

    def action(self, state: RigState) -> np.ndarray:
        unit = self.control(self.estimate(state))
        self.advance(self._filtered_rad)
        return np.array([unit], dtype=np.float32)

    def __call__(self, observation, state: RigState) -> np.ndarray:
        return self.action(state)


class StateFeedback:
    """u = -K x on the measured state [arm, pendulum from upright, arm rate, pendulum rate]: a gain designed
    by hand (lab 04's own `lqr_gain`) driving the env's continuous action, clipped to the servo's range.

    Nothing else is added (no filter state, no delay, no observer), so make the env with its action filter
    off (`filter_coefficient=0`): what balances, or falls, is the gain itself.
    """

    def __init__(self, gain, params: RigParams | None = None) -> None:
        try:
            given = np.asarray(gain, dtype=float)
        except (TypeError, ValueError):
            raise ConfigError(f"the gain must be 4 numbers (K is 1x4), got {type(gain).__name__}") from None
        k = given.reshape(-1)
        if given.shape not in ((4,), (1, 4), (4, 1)) or not np.all(np.isfinite(k)):
            raise ConfigError(f"the gain must be 4 finite numbers (K is 1x4), got {np.asarray(gain).shape} "
                              f"{np.asarray(gain).tolist()}")
        self.gain = k
        self.params = params or RigParams()

    def action(self, state: RigState) -> np.ndarray:
        x = np.array([state.arm_angle_rad, angle_from_upright_rad(state), state.arm_velocity_rad_s,
                      state.pendulum_velocity_rad_s])
        target_rad = -float(self.gain @ x)
        return np.array([np.clip(target_rad / self.params.servo_range_rad, -1.0, 1.0)], dtype=np.float32)

    def __call__(self, observation, state: RigState) -> np.ndarray:
        return self.action(state)

