"""The rig's equations of motion from `RigParams`, and their linearisations (python-control objects).

Coordinates: arm angle phi about the vertical axis, pendulum angle alpha about the arm's axis from the
bottom (alpha = pi is upright). The input is the servo's *target* angle: the servo's PD drive (clipped
at the stall torque) and back-EMF damping turn it into a torque, as in the MuJoCo twin.

Lagrangian of a Furuta pendulum with its pivot at radius r, pendulum mass m, centre of mass l from the
pivot, inertia J about the pivot and I_long about its own long axis:

    M(alpha) [phi'', alpha''] = rhs
    M = [[I0 + (J - I_long) sin^2 alpha,  m r l cos alpha],
         [m r l cos alpha,                J              ]]
    rhs_phi   = tau - c phi' - 2 (J - I_long) sin alpha cos alpha phi' alpha' + m r l sin alpha alpha'^2
    rhs_alpha = (J - I_long) sin alpha cos alpha phi'^2 - m g l sin alpha - b alpha'
    tau = clip(kp (target - phi) - kv phi', +-stall)

where I0 is everything the servo turns with the pendulum hanging (arm, horn, encoder and mount,
the pendulum's mass at radius r and its I_long, the gear train's reflected inertia).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import control
import numpy as np
import scipy.linalg

from pendkit.errors import ConfigError
from pendkit.rig import GRAVITY_M_S2, RigParams

STATE_NAMES = ("arm_angle_rad", "pendulum_angle_rad", "arm_velocity_rad_s", "pendulum_velocity_rad_s")
INPUT_NAMES = ("servo_target_rad",)
Equilibrium = Literal["upright", "hanging"]


@dataclass(frozen=True)
class FurutaModel:
    """Lumped parameters of the equations above, in SI units."""

    arm_inertia_kg_m2: float          # I0
    pendulum_inertia_kg_m2: float     # J, about the pivot axis
    pendulum_long_axis_inertia_kg_m2: float  # I_long
    coupling_kg_m2: float             # m r l
    gravity_torque_n_m: float         # m g l
    pendulum_damping_n_m_s_per_rad: float   # b
    arm_damping_n_m_s_per_rad: float  # c, back-EMF
    servo_kp_n_m_per_rad: float
    servo_kv_n_m_s_per_rad: float
    servo_stall_torque_n_m: float
    servo_range_rad: float

    @classmethod
    def from_rig(cls, params: RigParams | None = None) -> FurutaModel:
        """Mass properties from RigParams (the same parts, shapes and masses the twin's MJCF is built from)."""
        p = params or RigParams()
        r = p.pivot_radius_m
        mass, com = p.pendulum_mass_kg, p.pendulum_com_from_pivot_m
        return cls(
            arm_inertia_kg_m2=p.arm_inertia_kg_m2 + p.servo_reflected_inertia_kg_m2,
            pendulum_inertia_kg_m2=p.pendulum_inertia_about_pivot_kg_m2,
            pendulum_long_axis_inertia_kg_m2=p.pendulum_long_axis_inertia_kg_m2,
            coupling_kg_m2=mass * r * com,
            gravity_torque_n_m=mass * GRAVITY_M_S2 * com,
            pendulum_damping_n_m_s_per_rad=p.pendulum_damping_n_m_s_per_rad,
            arm_damping_n_m_s_per_rad=p.servo_back_emf_damping_n_m_s_per_rad,
            servo_kp_n_m_per_rad=p.servo_kp_n_m_per_rad,
            servo_kv_n_m_s_per_rad=p.servo_kv_n_m_s_per_rad,
            servo_stall_torque_n_m=p.servo_stall_torque_n_m,
            servo_range_rad=p.servo_range_rad,
        )

    @property
    def natural_frequency_rad_s(self) -> float:
        """Small swings with the arm held: sqrt(m g l / J)."""
        return math.sqrt(self.gravity_torque_n_m / self.pendulum_inertia_kg_m2)

    def servo_torque_n_m(self, target_rad, arm_rad, arm_velocity_rad_s):
        """The servo's drive torque (scalars or arrays): PD on the target, clipped at the stall torque."""
        drive = self.servo_kp_n_m_per_rad * (target_rad - arm_rad) - self.servo_kv_n_m_s_per_rad * arm_velocity_rad_s
        return np.clip(drive, -self.servo_stall_torque_n_m, self.servo_stall_torque_n_m)

    def accelerations(self, state: np.ndarray, target_rad) -> np.ndarray:
        """[phi'', alpha''] of the nonlinear model at state [phi, alpha, phi', alpha'].

        Also for many states at once: `state` of shape (4, n) and `target_rad` a number or n of them give
        shape (2, n) (the trajectory optimiser simulates thousands of input sequences together).
        """
        phi, alpha, phi_dot, alpha_dot = state
        s, c = np.sin(alpha), np.cos(alpha)
        extra = self.pendulum_inertia_kg_m2 - self.pendulum_long_axis_inertia_kg_m2
        m_arm = self.arm_inertia_kg_m2 + extra * s * s
        m_cross = self.coupling_kg_m2 * c
        m_pend = self.pendulum_inertia_kg_m2
        torque = self.servo_torque_n_m(target_rad, phi, phi_dot)
        rhs_arm = (torque - self.arm_damping_n_m_s_per_rad * phi_dot - 2 * extra * s * c * phi_dot * alpha_dot
                   + self.coupling_kg_m2 * s * alpha_dot**2)
        rhs_pend = (extra * s * c * phi_dot**2 - self.gravity_torque_n_m * s
                    - self.pendulum_damping_n_m_s_per_rad * alpha_dot)
        det = m_arm * m_pend - m_cross * m_cross  # > 0: the mass matrix is positive definite
        return np.array([(m_pend * rhs_arm - m_cross * rhs_pend) / det, (m_arm * rhs_pend - m_cross * rhs_arm) / det])

    def linearise(self, about: Equilibrium = "upright") -> control.StateSpace:
        """Continuous-time model about an equilibrium, with the servo unsaturated.

        States: arm angle (rad), pendulum angle *from the equilibrium* (rad), their rates (rad/s).
        Input: servo target (rad). Outputs: the four states.
        """
        if about not in ("upright", "hanging"):
            raise ConfigError(f"about must be 'upright' or 'hanging', got {about!r}")
        sign = -1.0 if about == "upright" else 1.0  # cos(alpha) at the equilibrium
        mass = np.array([[self.arm_inertia_kg_m2, sign * self.coupling_kg_m2],
                         [sign * self.coupling_kg_m2, self.pendulum_inertia_kg_m2]])
        # rhs = F x + G u with x = [phi, theta, phi', theta']; sin(alpha) = -theta upright, +theta hanging
        forces = np.array([
            [-self.servo_kp_n_m_per_rad, 0.0, -(self.servo_kv_n_m_s_per_rad + self.arm_damping_n_m_s_per_rad), 0.0],
            [0.0, sign * -self.gravity_torque_n_m, 0.0, -self.pendulum_damping_n_m_s_per_rad],
        ])
        inverse = np.linalg.inv(mass)
        a = np.zeros((4, 4))
        a[0, 2] = a[1, 3] = 1.0
        a[2:, :] = inverse @ forces
        b = np.zeros((4, 1))
        b[2:, 0] = inverse @ np.array([self.servo_kp_n_m_per_rad, 0.0])
        return control.ss(a, b, np.eye(4), np.zeros((4, 1)), states=list(STATE_NAMES), inputs=list(INPUT_NAMES),
                          outputs=list(STATE_NAMES), name=f"furuta_{about}")


def discretise(system: control.StateSpace, period_s: float) -> control.StateSpace:
    """Zero-order-hold discretisation at the control period (the target is held for a whole step)."""
    if not period_s > 0:
        raise ConfigError(f"period_s must be > 0, got {period_s}")
    return control.c2d(system, period_s, method="zoh")


def filtered_model(system: control.StateSpace, period_s: float, filter_coefficient: float,
                   input_delay_s: float = 0.0) -> control.StateSpace:
    """The discrete model the env's continuous action really drives: ZOH at `period_s`, the action
    filter a_k = c a_(k-1) + (1 - c) u_k, and the target reaching the servo `input_delay_s` into the step.

    Extra state: the previous filtered target a_(k-1) (rad), which is also the target in force until the
    delayed new one arrives. Input: the raw target u_k (rad). With the delay d < T the step splits:
    a_(k-1) acts for d, a_k for T - d (the standard fractional-delay discretisation).
    """
    if system.isdtime(strict=True):
        raise ConfigError("filtered_model needs the continuous-time model from linearise()")
    c = filter_coefficient
    if not 0 <= c < 1:
        raise ConfigError(f"filter_coefficient must be in [0, 1), got {c}")
    if not 0 <= input_delay_s < period_s:
        raise ConfigError(f"input_delay_s must be in [0, period_s={period_s}), got {input_delay_s}")
    a, b = np.asarray(system.A), np.asarray(system.B)
    n = a.shape[0]
    a_step, b_new = _zoh(a, b, period_s - input_delay_s)   # the new target, for the last T - d
    a_delay, b_old = _zoh(a, b, input_delay_s)             # the old target, for the first d
    a_d = a_step @ a_delay
    b_prev = a_step @ b_old
    a_aug = np.zeros((n + 1, n + 1))
    a_aug[:n, :n] = a_d
    a_aug[:n, n:] = b_prev + c * b_new
    a_aug[n, n] = c
    b_aug = np.vstack([(1 - c) * b_new, [[1 - c]]])
    states = [*system.state_labels, "filtered_target_rad"]
    return control.ss(a_aug, b_aug, np.eye(n + 1), np.zeros((n + 1, 1)), period_s, states=states,
                      inputs=["raw_target_rad"], outputs=states, name=f"{system.name}_filtered")


def _zoh(a: np.ndarray, b: np.ndarray, duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(e^(A t), integral of e^(A s) ds B over [0, t]) from one matrix exponential."""
    n, m = a.shape[0], b.shape[1]
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = a * duration_s, b * duration_s
    exp = scipy.linalg.expm(block)
    return exp[:n, :n], exp[:n, n:]
