"""Energy-based swing-up (Astrom & Furuta 2000) through arm motion, handing over to LQR near upright.

The pendulum's energy, normalised by m g l, is e = 0.5 (alpha'/w0)^2 - cos(alpha): -1 hanging still,
+1 upright still. From the equations of motion (pendkit.control.model) the pivot's motion changes it at
de/dt = -(m r l / m g l) cos(alpha) alpha' phi'' (plus damping), so accelerating the arm against
sign(alpha' cos(alpha)) pumps energy in. Our input is the servo's target, a *position*: for a swing,
position is half a period out of phase with acceleration, so the target goes *with*
sign(alpha' cos(alpha)), by an amount that grows with the energy still missing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pendkit.control.lqr import LqrBalancer
from pendkit.errors import ConfigError
from pendkit.features import angle_from_upright_rad
from pendkit.rig import RigParams
from pendkit.state import RigState


@dataclass(frozen=True)
class SwingUpConfig:
    """Swing-up law and hand-over thresholds.

    energy_gain: arm target amplitude per unit of missing normalised energy (saturates at 1).
    swing_amplitude_rad: the largest arm target while pumping; keep it inside the servo's range.
    target_energy: normalised energy to pump to; 1.0 is exactly enough to stand upright.
    catch_angle_rad, catch_velocity_rad_s: hand over to LQR inside both.
    fall_angle_rad: give the pendulum back to the swing-up beyond this angle from upright.
    phase_lead_rad: how far ahead in its swing (radians of phase at the natural frequency) the pendulum
        is predicted when choosing the pumping side, to make up for the loop's lag from deciding to the
        arm moving (filter, hold, delays, servo). None: estimated from the env by `loop_phase_lag_rad`.
    """

    energy_gain: float = 3.0
    swing_amplitude_rad: float = 1.2
    target_energy: float = 1.05
    catch_angle_rad: float = 0.4
    catch_velocity_rad_s: float = 5.0
    fall_angle_rad: float = 0.9
    phase_lead_rad: float | None = None

    def __post_init__(self) -> None:
        for name, value in self.__dict__.items():
            if name == "phase_lead_rad" and (value is None or (math.isfinite(value) and 0 <= value < math.pi)):
                continue
            if not (math.isfinite(value) and value > 0):
                raise ConfigError(f"SwingUpConfig.{name} must be > 0, got {value}")
        if self.catch_angle_rad >= self.fall_angle_rad:
            raise ConfigError(f"catch_angle_rad ({self.catch_angle_rad}) must be below fall_angle_rad "
                              f"({self.fall_angle_rad}), or the controller would hand over and back at once")
        if self.swing_amplitude_rad > math.pi / 2:
            raise ConfigError(f"swing_amplitude_rad must be within the servo's range (pi/2), got "
                              f"{self.swing_amplitude_rad}")


def loop_phase_lag_rad(balancer: LqrBalancer, loop_delay_s: float = 0.0,
                       filter_coefficient: float | None = None) -> float:
    """Phase lag, at the pendulum's natural frequency, from choosing a target to the arm following it.

    Sum of: the action filter (first order, time constant -T / ln c), half a step of zero-order hold,
    the loop's delay, and the servo's position loop (second order from its kp, damping and inertia).
    """
    w = balancer.model.natural_frequency_rad_s
    period = balancer.period_s
    c = balancer.filter_coefficient if filter_coefficient is None else filter_coefficient
    lag = w * (period / 2 + loop_delay_s)
    if c > 0:
        lag += math.atan(w * -period / math.log(c))
    model = balancer.model
    servo_w = math.sqrt(model.servo_kp_n_m_per_rad / model.arm_inertia_kg_m2)
    servo_zeta = (model.servo_kv_n_m_s_per_rad + model.arm_damping_n_m_s_per_rad) / (
        2 * math.sqrt(model.servo_kp_n_m_per_rad * model.arm_inertia_kg_m2))
    ratio = w / servo_w
    lag += math.atan2(2 * servo_zeta * ratio, 1 - ratio * ratio)
    return lag


def normalised_energy(state: RigState, natural_frequency_rad_s: float) -> float:
    """0.5 (alpha'/w0)^2 - cos(alpha): -1 hanging still, +1 upright still."""
    return 0.5 * (state.pendulum_velocity_rad_s / natural_frequency_rad_s) ** 2 - math.cos(state.pendulum_angle_rad)


class SwingUpController:
    """Swing up, catch with LQR, and swing up again after a fall. `mode` is "swing" or "balance"."""

    def __init__(self, balancer: LqrBalancer, config: SwingUpConfig | None = None,
                 params: RigParams | None = None, loop_delay_s: float = 0.0) -> None:
        self.balancer = balancer
        self.config = config or SwingUpConfig()
        self.params = params or balancer.params
        self.natural_frequency_rad_s = balancer.model.natural_frequency_rad_s
        # The env's own filter: none when the balancer filters internally.
        self.env_filter_coefficient = 0.0 if balancer.internal_filter else balancer.filter_coefficient
        self.phase_lead_rad = (self.config.phase_lead_rad if self.config.phase_lead_rad is not None
                               else loop_phase_lag_rad(balancer, loop_delay_s, self.env_filter_coefficient))
        self.mode = "swing"
        self.switches = 0
        self._filtered_rad = 0.0

    @classmethod
    def for_env(cls, env, config: SwingUpConfig | None = None, **lqr_kwargs) -> SwingUpController:
        balancer = LqrBalancer.for_env(env, **lqr_kwargs)
        return cls(balancer, config, env.unwrapped.params, loop_delay_s=balancer.delay_s)

    def reset(self, state: RigState) -> None:
        self.mode, self.switches = "swing", 0
        self._filtered_rad = state.servo_target_rad
        self.balancer.reset(state)

    def swing_target_rad(self, state: RigState) -> float:
        """The arm target that pumps energy towards `target_energy` (or bleeds off any excess)."""
        cfg = self.config
        missing = cfg.target_energy - normalised_energy(state, self.natural_frequency_rad_s)
        # Rotate the swing's phase-space point (alpha, alpha'/w0) forward by the lead: exact for small swings.
        w0, lead = self.natural_frequency_rad_s, self.phase_lead_rad
        angle = (state.pendulum_angle_rad + math.pi) % (2 * math.pi) - math.pi  # from the bottom, wrapped
        rate = state.pendulum_velocity_rad_s / w0
        alpha = angle * math.cos(lead) + rate * math.sin(lead)
        alpha_dot = rate * math.cos(lead) - angle * math.sin(lead)
        direction = math.copysign(1.0, alpha_dot * math.cos(alpha))
        return direction * cfg.swing_amplitude_rad * max(-1.0, min(1.0, cfg.energy_gain * missing))

    def action(self, state: RigState) -> np.ndarray:
        theta = angle_from_upright_rad(state)
        cfg = self.config
        if self.mode == "swing" and abs(theta) < cfg.catch_angle_rad \
                and abs(state.pendulum_velocity_rad_s) < cfg.catch_velocity_rad_s:
            self.mode, self.switches = "balance", self.switches + 1
            # With the filter inside the balancer it may start where the arm is, not at the last swing
            # target (which can be a full swing away); with the env's filter it must match the env's.
            start = state.arm_angle_rad if self.balancer.internal_filter else self._filtered_rad
            self.balancer.reset(state._replace(servo_target_rad=start))
        elif self.mode == "balance" and abs(theta) > cfg.fall_angle_rad:
            self.mode, self.switches = "swing", self.switches + 1
        if self.mode == "balance":
            action = self.balancer.action(state)
        else:
            action = self._towards(self.swing_target_rad(state))
        c = self.env_filter_coefficient
        self._filtered_rad = c * self._filtered_rad + (1 - c) * float(action[0]) * self.params.servo_range_rad
        return action

    def _towards(self, target_rad: float) -> np.ndarray:
        """The raw action whose filtered value lands on `target_rad` (inverting the env's filter)."""
        c = self.env_filter_coefficient
        raw_rad = (target_rad - c * self._filtered_rad) / (1 - c)
        return np.array([np.clip(raw_rad / self.params.servo_range_rad, -1.0, 1.0)], dtype=np.float32)

    def __call__(self, observation, state: RigState) -> np.ndarray:
        return self.action(state)
