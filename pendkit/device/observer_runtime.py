"""The device's bank of observers for a learned policy (layout 2), in scalar arithmetic as the firmware's core
would run it: each candidate predicts the pendulum over a control step with its rigid-body model (RK4 in 5 ms
substeps, the new target in force after the actuation delay) and corrects with the newest encoder angle
compared with its prediction at the reading's own time; the candidate whose model has lately predicted the
readings best is the one shown. The host's `pendkit.control.observer_bank` is the design this mirrors
(tests/device/test_observed_policy.py holds the two together)."""

from __future__ import annotations

import math

from pendkit.backend_contract import RigState
from pendkit.device.observer_blob import ObserverSection

SUBSTEP_S = 0.005
MAX_SUBSTEPS = 64  # a control step of at most 0.32 s: each observer keeps a prediction per substep


class CandidateObserver:
    """Estimate [arm angle, pendulum angle from the bottom, their rates] with one candidate's model."""

    def __init__(self, model, gain, period_s: float, actuation_delay_s: float, reading_latency_s: float) -> None:
        (self.i_arm, self.j_pend, self.i_long, self.coupling, self.gravity, self.b_pend, self.c_arm, self.kp,
         self.kv, self.stall, self.range_rad) = (float(v) for v in model)
        self.extra = self.j_pend - self.i_long
        self.gain = [float(g) for g in gain]
        self.steps = max(1, math.floor(period_s / SUBSTEP_S + 0.5))  # halves up, as the C++ core rounds
        self.switch = math.floor(actuation_delay_s / SUBSTEP_S + 0.5)
        self.reading_latency_s = reading_latency_s
        self.x = [0.0, 0.0, 0.0, 0.0]
        self.target_rad = 0.0
        self.history: list[float] = []  # the predicted pendulum angle after each substep of the last step
        self.innovation_rad = 0.0

    def reset(self, state: RigState) -> None:
        self.x = [state.arm_angle_rad, state.pendulum_angle_rad, state.arm_velocity_rad_s,
                  state.pendulum_velocity_rad_s]
        self.target_rad = state.servo_target_rad
        self.history = []

    def accelerations(self, x, target_rad: float) -> tuple[float, float]:
        phi, alpha, phi_dot, alpha_dot = x
        s, c = math.sin(alpha), math.cos(alpha)
        m_arm, m_cross = self.i_arm + self.extra * s * s, self.coupling * c
        drive = self.kp * (target_rad - phi) - self.kv * phi_dot
        torque = min(max(drive, -self.stall), self.stall)
        rhs_arm = (torque - self.c_arm * phi_dot - 2 * self.extra * s * c * phi_dot * alpha_dot
                   + self.coupling * s * alpha_dot * alpha_dot)
        rhs_pend = self.extra * s * c * phi_dot * phi_dot - self.gravity * s - self.b_pend * alpha_dot
        det = m_arm * self.j_pend - m_cross * m_cross
        return (self.j_pend * rhs_arm - m_cross * rhs_pend) / det, (m_arm * rhs_pend - m_cross * rhs_arm) / det

    def _rk4(self, x, target_rad: float, dt: float):
        def derivative(s):
            a_arm, a_pend = self.accelerations(s, target_rad)
            return (s[2], s[3], a_arm, a_pend)

        def moved(k, by):
            return [xi + by * ki for xi, ki in zip(x, k)]

        k1 = derivative(x)
        k2 = derivative(moved(k1, dt / 2))
        k3 = derivative(moved(k2, dt / 2))
        k4 = derivative(moved(k3, dt))
        return [xi + dt / 6 * (a + 2 * b + 2 * c + d) for xi, a, b, c, d in zip(x, k1, k2, k3, k4)]

    def predict(self, target_unit: float) -> None:
        """Advance one control step in which the target `target_unit` (of the servo's range) arrives after the
        actuation delay; the older target acts until then."""
        limit = self.range_rad
        new_target = target_unit * limit
        x, target = self.x, self.target_rad
        self.history = []
        for k in range(self.steps):
            if k == self.switch:
                target = new_target
            x = self._rk4(x, target, SUBSTEP_S)
            target = min(max(target, -limit), limit)
            self.history.append(x[1])
        self.x, self.target_rad = x, (new_target if self.switch >= self.steps else target)

    def correct(self, state: RigState) -> None:
        """Fold in the newest reading, compared with the prediction at its own moment (the older substep on a
        tie, as the host's observer)."""
        age_s = state.observation_age_s + self.reading_latency_s
        predicted = self.x[1]
        if self.history:
            last = len(self.history) - 1
            nearest = min(range(last + 1), key=lambda k: abs((last - k) * SUBSTEP_S - age_s))
            predicted = self.history[nearest]
        innovation = (state.pendulum_angle_rad - predicted + math.pi) % (2 * math.pi) - math.pi
        self.x = [xi + g * innovation for xi, g in zip(self.x, self.gain)]
        self.innovation_rad = innovation

    def shown(self, state: RigState) -> RigState:
        """`state` with the estimate's angles and rates, and the model's pendulum acceleration."""
        x = self.x
        _, pendulum_acceleration = self.accelerations(x, self.target_rad)
        return state._replace(arm_angle_rad=x[0], pendulum_angle_rad=x[1] % (2 * math.pi), arm_velocity_rad_s=x[2],
                              pendulum_velocity_rad_s=x[3], pendulum_acceleration_rad_s2=pendulum_acceleration)


class DeviceObserverBank:
    """`reset(state)` and `update(target_unit, state)` return the state to show the policy."""

    def __init__(self, section: ObserverSection, period_s: float) -> None:
        self.observers = [CandidateObserver(model, gain, period_s, section.actuation_delay_s, section.reading_latency_s)
                          for model, gain in zip(section.models, section.gains)]
        self.forgetting = section.forgetting
        self.misses = [0.0] * len(self.observers)
        self.chosen = 0

    def reset(self, state: RigState) -> RigState:
        for observer in self.observers:
            observer.reset(state)
        self.misses = [0.0] * len(self.observers)
        self.chosen = 0
        return self.observers[0].shown(state)

    def update(self, target_unit: float, state: RigState) -> RigState:
        for k, observer in enumerate(self.observers):
            observer.predict(target_unit)
            observer.correct(state)
            self.misses[k] += self.forgetting * (observer.innovation_rad ** 2 - self.misses[k])
        self.chosen = min(range(len(self.misses)), key=self.misses.__getitem__)
        return self.observers[self.chosen].shown(state)
