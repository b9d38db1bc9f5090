"""Energy-based swing-up (Astrom & Furuta 2000) through arm motion, handing over to LQR near upright.

The pendulum's energy, normalised by m g l, is e = 0.5 (alpha'/w0)^2 - cos(alpha): -1 hanging still,
+1 upright still. From the equations of motion (pendkit.control.model) the pivot's motion changes it at
de/dt = -(m r l / m g l) cos(alpha) alpha' phi'' (plus damping), so an arm acceleration against
alpha' cos(alpha) pumps energy in. Since d/dt sin(alpha) = alpha' cos(alpha), that acceleration
integrates to an arm *velocity* against sin(alpha), at any amplitude. A position servo is good at
velocities: the controller moves its target at a set rate, towards -sign(sin(alpha)), scaled by the
energy still missing (and reversed to brake when there is too much), with a weak pull to the centre so
the arm stays inside its range.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pendkit.backend_contract import RigState
from pendkit.checks import check_fields, is_finite_number
from pendkit.control.lqr import LqrBalancer
from pendkit.errors import ConfigError
from pendkit.features import angle_from_upright_rad, pendulum_energy
from pendkit.rig import RigParams


@dataclass(frozen=True)
class SwingUpConfig:
    """Swing-up law and hand-over thresholds. Defaults: chosen on 20 random starts of the twin
    (benchmarks/bench_swingup.py has the figures); the rate is just under the D645MW's 5.24 rad/s.

    energy_gain: fraction of the full swing rate per unit of missing normalised energy (saturates at 1).
    swing_rate_rad_s: how fast the target moves while pumping (at most the servo's rated speed).
    centring_per_s: pull of the target back to the centre, as a rate per radian of target.
    arm_limit_rad: the target never goes further out than this while pumping.
    target_energy: normalised energy to pump to; 1.0 is exactly enough to stand upright.
    catch_angle_rad, catch_velocity_rad_s: hand over to LQR inside both.
    fall_angle_rad: give the pendulum back to the swing-up beyond this angle from upright.
    phase_lead_rad: how far ahead in its swing (radians of phase at the natural frequency) the pendulum
        is predicted when choosing the pumping side. The velocity law needs none on the twin (measured:
        0 beats the position-loop lag estimate); None estimates it with `loop_phase_lag_rad`.
    """

    energy_gain: float = 1.0
    swing_rate_rad_s: float = 5.0
    centring_per_s: float = 1.0
    arm_limit_rad: float = 1.2
    target_energy: float = 1.0
    catch_angle_rad: float = 0.8
    catch_velocity_rad_s: float = 5.0
    fall_angle_rad: float = 1.1
    phase_lead_rad: float | None = 0.0

    def __post_init__(self) -> None:
        check_fields(self, lambda setting: setting > 0, "> 0", skip=("phase_lead_rad",))
        lead = self.phase_lead_rad
        if lead is not None and not (is_finite_number(lead) and 0 <= lead < math.pi):
            raise ConfigError(f"SwingUpConfig.phase_lead_rad must be None or in [0, pi), got {lead!r}")
        if self.catch_angle_rad >= self.fall_angle_rad:
            raise ConfigError(f"catch_angle_rad ({self.catch_angle_rad}) must be below fall_angle_rad "
                              f"({self.fall_angle_rad}), or the controller would hand over and back at once")
        if self.arm_limit_rad > math.pi / 2:
            raise ConfigError(f"arm_limit_rad must be within the servo's range (pi/2), got {self.arm_limit_rad}")


def pumping_acceleration_sign(angle_from_bottom_rad: float, velocity_rad_s: float) -> int:
    """+1 or -1: the sign of arm acceleration that adds energy, that of -alpha' cos(alpha)."""
    return -1 if velocity_rad_s * math.cos(angle_from_bottom_rad) > 0 else 1


@dataclass(frozen=True)
class SwingUpParts:
    """The swing-up's three decisions, each replaceable by a student's own function (lab 05).

    energy(angle_from_bottom_rad, velocity_rad_s, natural_frequency_rad_s) -> normalised energy.
    direction(angle_from_bottom_rad, velocity_rad_s) -> +1 or -1, the arm acceleration that pumps.
    next_mode(mode, angle_from_upright_rad, velocity_rad_s) -> "swing" or "balance" (None: the
        config's catch and fall thresholds).
    """

    energy: Callable = pendulum_energy
    direction: Callable = pumping_acceleration_sign
    next_mode: Callable | None = None


# The servo follows a position, so the controller moves its target at a rate: the integral of the
# acceleration the pumping rule asks for. For a swing, the integral of that square wave is a triangle a
# quarter period behind it, so the rate's sign now is the rule's answer for the same swing a quarter period
# earlier: the phase point (alpha, alpha'/w0) turned back by 90 degrees, (-alpha'/w0, alpha). It is asked
# about a swing of at most this amplitude (the phase is what matters, and the small-swing picture holds).
_EARLIER_SWING_RAD = 1.2


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


class SwingUpController:
    """Swing up, catch with LQR, and swing up again after a fall. `mode` is "swing" or "balance"."""

    def __init__(self, balancer: LqrBalancer, config: SwingUpConfig | None = None,
                 params: RigParams | None = None, loop_delay_s: float = 0.0, parts: SwingUpParts | None = None) -> None:
        self.balancer = balancer
        self.config = config or SwingUpConfig()
        self.parts = parts or SwingUpParts()
        self.params = params or balancer.params
        self.natural_frequency_rad_s = balancer.model.natural_frequency_rad_s
        # The env's own filter: none when the balancer filters internally.
        self.env_filter_coefficient = 0.0 if balancer.internal_filter else balancer.filter_coefficient
        self.phase_lead_rad = (self.config.phase_lead_rad if self.config.phase_lead_rad is not None
                               else loop_phase_lag_rad(balancer, loop_delay_s, self.env_filter_coefficient))
        self.mode = "swing"
        self.switches = 0
        self._filtered_rad = self._swing_target_rad = 0.0

    @classmethod
    def for_env(cls, env, config: SwingUpConfig | None = None, parts: SwingUpParts | None = None,
                **lqr_kwargs) -> SwingUpController:
        balancer = LqrBalancer.for_env(env, **lqr_kwargs)
        return cls(balancer, config, env.unwrapped.params, loop_delay_s=env.unwrapped.timing.loop_delay_s,
                   parts=parts)

    def reset(self, state: RigState) -> None:
        self.mode, self.switches = "swing", 0
        self._filtered_rad = self._swing_target_rad = state.servo_target_rad
        self.balancer.reset(state)

    def swing_rate_rad_s(self, state: RigState) -> float:
        """The target's rate that pumps energy towards `target_energy` (or bleeds off any excess)."""
        cfg = self.config
        w0, lead = self.natural_frequency_rad_s, self.phase_lead_rad
        energy = _number(self.parts.energy(state.pendulum_angle_rad, state.pendulum_velocity_rad_s, w0), "energy")
        missing = cfg.target_energy - energy
        # Rotate the swing's phase-space point (alpha, alpha'/w0) forward by the lead: exact for small swings.
        angle = (state.pendulum_angle_rad + math.pi) % (2 * math.pi) - math.pi  # from the bottom, wrapped
        rate = state.pendulum_velocity_rad_s / w0
        alpha, rate = angle * math.cos(lead) + rate * math.sin(lead), rate * math.cos(lead) - angle * math.sin(lead)
        earlier_angle, earlier_rate = -rate, alpha  # a quarter period back (see _EARLIER_SWING_RAD)
        scale = min(1.0, _EARLIER_SWING_RAD / max(math.hypot(earlier_angle, earlier_rate), 1e-12))
        direction = _number(self.parts.direction(earlier_angle * scale, earlier_rate * scale * w0), "direction")
        if direction not in (-1.0, 1.0):
            raise ConfigError(f"the pumping direction must be +1 or -1, got {direction!r}")
        pumping = direction * cfg.swing_rate_rad_s * max(-1.0, min(1.0, cfg.energy_gain * missing))
        return pumping - cfg.centring_per_s * self._swing_target_rad

    def _next_mode(self, theta: float, velocity_rad_s: float) -> str:
        if self.parts.next_mode is not None:
            mode = self.parts.next_mode(self.mode, theta, velocity_rad_s)
            if mode not in ("swing", "balance"):
                raise ConfigError(f"next_mode must return 'swing' or 'balance', got {mode!r}")
            return mode
        cfg = self.config
        if self.mode == "swing" and abs(theta) < cfg.catch_angle_rad and abs(velocity_rad_s) < cfg.catch_velocity_rad_s:
            return "balance"
        if self.mode == "balance" and abs(theta) > cfg.fall_angle_rad:
            return "swing"
        return self.mode

    def action(self, state: RigState) -> np.ndarray:
        return self.act(self.balancer.estimate(state))

    def act(self, estimate: RigState) -> np.ndarray:
        """The action for a state already passed through the balancer's estimator."""
        theta = angle_from_upright_rad(estimate)
        cfg = self.config
        mode = self._next_mode(theta, estimate.pendulum_velocity_rad_s)
        if mode == "balance" and self.mode == "swing":
            self.mode, self.switches = "balance", self.switches + 1
            # With the filter inside the balancer it may start where the arm is, not at the last swing
            # target (which can be a full swing away); with the env's filter it must match the env's.
            start = estimate.arm_angle_rad if self.balancer.internal_filter else self._filtered_rad
            self.balancer.reset(estimate._replace(servo_target_rad=start), keep_estimate=True)
        elif mode == "swing" and self.mode == "balance":
            self.mode, self.switches = "swing", self.switches + 1
            self._swing_target_rad = self._filtered_rad
        if self.mode == "balance":
            unit = self.balancer.control(estimate)
        else:
            limit = cfg.arm_limit_rad
            step = self.swing_rate_rad_s(estimate) * self.balancer.period_s
            self._swing_target_rad = max(-limit, min(limit, self._swing_target_rad + step))
            unit = self._towards(self._swing_target_rad)
        c = self.env_filter_coefficient
        self._filtered_rad = c * self._filtered_rad + (1 - c) * unit * self.params.servo_range_rad
        self.balancer.advance(self._filtered_rad)
        return np.array([unit], dtype=np.float32)

    @property
    def target_in_force_rad(self) -> float:
        """The servo target the last action left in force (after the env's filter, if any)."""
        return self._filtered_rad

    def follow(self, target_rad: float) -> np.ndarray:
        """Send `target_rad` for another controller (the trajectory tracker), keeping the filter, the
        observer and the next swing's starting point as if it had been ours."""
        self._swing_target_rad = max(-self.params.servo_range_rad, min(self.params.servo_range_rad, target_rad))
        unit = self._towards(self._swing_target_rad)
        c = self.env_filter_coefficient
        self._filtered_rad = c * self._filtered_rad + (1 - c) * unit * self.params.servo_range_rad
        self.balancer.advance(self._filtered_rad)
        return np.array([unit], dtype=np.float32)

    def _towards(self, target_rad: float) -> float:
        """The raw action whose filtered value lands on `target_rad` (inverting the env's filter)."""
        c = self.env_filter_coefficient
        raw_rad = (target_rad - c * self._filtered_rad) / (1 - c)
        return float(np.clip(raw_rad / self.params.servo_range_rad, -1.0, 1.0))

    def __call__(self, observation, state: RigState) -> np.ndarray:
        return self.action(state)


def _number(value, what: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(f"the swing-up's {what} must be a number, got {type(value).__name__}") from None
    if not math.isfinite(number):
        raise ConfigError(f"the swing-up's {what} must be finite, got {number}")
    return number
