"""The device's swing-up controller (blob kind 3), as the firmware's core runs it: every acting tick it
reads the encoder and updates its estimate; every control step it chooses the servo target.

The estimate costs a few float operations a tick and has no delay to undo, since the device reads the
encoder itself: the pendulum's angle and rate by a two-state Kalman filter whose prediction includes
gravity, damping and the arm's push on the pivot (the gains designed on the host), the arm by the
servo's model (PD drive clipped at the stall torque) driven by the target in force (a hobby servo
reports nothing), each target one acting tick late: the servo takes a new target at its next PWM frame,
which the device does not see (a 20 ms frame: half of one, a 10 ms acting tick, on average). Without that
delay the estimate ran ahead of a fast, lightly damped servo (the HSB-9380TH preset) and the balance
fell. The control law is the host's (`pendkit.control`): follow the plan from rest with its time-varying
gains when there is one and the pendulum starts at rest, settle with the plan's own LQR, else pump
energy; LQR with its action filter near upright; pump again after a fall. The firmware's `pend::SwingUp`
(firmware/lib/pendcore/src/swingup.cpp) is line for line the same.
"""

from __future__ import annotations

import math

from pendkit.device.swingup_blob import SwingUpBlob

TWO_PI = 2 * math.pi
EARLIER_SWING_RAD = 1.2  # as pendkit.control.swingup._EARLIER_SWING_RAD
MODES = ("wait", "track", "settle", "swing", "balance")
ARM_SUBSTEPS = 2


def pendulum_acceleration(angle_rad: float, rate_rad_s: float, arm_acceleration_rad_s2: float,
                          natural_frequency_rad_s: float, damping_per_s: float, coupling: float) -> float:
    """The pendulum's angular acceleration (angle from the bottom): gravity, the bearing's damping and the
    arm's push on the pivot, the second row of pendkit.control.model divided by the pendulum's inertia
    (its small centrifugal term left out)."""
    return (-natural_frequency_rad_s ** 2 * math.sin(angle_rad) - damping_per_s * rate_rad_s
            - coupling * math.cos(angle_rad) * arm_acceleration_rad_s2)


def wrap_pi(angle_rad: float) -> float:
    """The angle in [-pi, pi)."""
    return (angle_rad + math.pi) % TWO_PI - math.pi


def clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


class SwingUpRuntime:
    """`reset(pendulum_rad, target_rad)` when started, then `tick(pendulum_rad, target_in_force_rad)` every
    acting tick -> the servo target (rad) to hold until the next tick."""

    def __init__(self, blob: SwingUpBlob) -> None:
        self.blob = blob
        self.pendulum_acceleration = pendulum_acceleration  # lab 10 puts a student's model here
        self.ticks_per_step = max(1, round(blob.period_s / blob.acting_period_s))
        self.reset(0.0, 0.0)

    def reset(self, pendulum_rad: float, target_rad: float) -> None:
        self.angle_rad, self.rate_rad_s = pendulum_rad, 0.0
        self.arm_rad, self.arm_rate_rad_s = target_rad, 0.0
        self.servo_sees_rad = target_rad  # what the servo drives to this tick (the target one tick back)
        self.output_rad = self.swing_target_rad = self.filtered_rad = target_rad
        self.mode = "wait" if self.blob.warmup_steps > 0 else self._first_mode()
        self.tick_count, self.steps, self.plan_step = 0, 0, 0

    # --- every acting tick ---
    def observe(self, pendulum_rad: float, target_in_force_rad: float) -> None:
        """Fold in one encoder reading (angle from the bottom); the arm's model advances one tick, driven by
        the target in force a tick ago (the servo's PWM frame delay, see the module docstring)."""
        b, dt = self.blob, self.blob.acting_period_s
        target_rad, self.servo_sees_rad = self.servo_sees_rad, target_in_force_rad
        arm_acceleration = self._arm_acceleration(target_rad)
        h = dt / ARM_SUBSTEPS
        for _ in range(ARM_SUBSTEPS):  # semi-implicit Euler: stable well beyond the servo's bandwidth
            self.arm_rate_rad_s += h * self._arm_acceleration(target_rad)
            self.arm_rad += h * self.arm_rate_rad_s
        acceleration = float(self.pendulum_acceleration(self.angle_rad, self.rate_rad_s, arm_acceleration,
                                                        b.natural_frequency_rad_s, b.pendulum_damping_per_inertia,
                                                        b.coupling_per_inertia))
        predicted = self.angle_rad + self.rate_rad_s * dt + 0.5 * acceleration * dt * dt
        rate = self.rate_rad_s + acceleration * dt
        innovation = wrap_pi(pendulum_rad - predicted)
        self.angle_rad = wrap_pi(predicted + b.observer_angle_gain * innovation)
        self.rate_rad_s = rate + b.observer_rate_gain * innovation

    def _arm_acceleration(self, target_rad: float) -> float:
        """The servo's clipped PD drive and back-EMF on the arm (the pendulum's push left out)."""
        b = self.blob
        drive = b.servo_kp_per_inertia * (target_rad - self.arm_rad) - b.servo_kv_per_inertia * self.arm_rate_rad_s
        return clamp(drive, b.stall_per_inertia) - b.arm_damping_per_inertia * self.arm_rate_rad_s

    def tick(self, pendulum_rad: float, target_in_force_rad: float) -> float:
        self.observe(pendulum_rad, target_in_force_rad)
        self.tick_count += 1
        if self.tick_count >= self.ticks_per_step:
            self.tick_count = 0
            self.output_rad = self.control_step()
        return self.output_rad

    # --- every control step ---
    def control_step(self) -> float:
        self.steps += 1
        if self.mode == "wait":
            if self.steps < self.blob.warmup_steps:
                return self.output_rad
            self.mode = self._first_mode()
        if self.mode == "track":
            target = self._track()
            if target is not None:
                return self._follow(target)
        if self.mode == "settle":
            target = self._settle()
            if target is not None:
                return self._follow(target)
        return self._swing_or_balance()

    def _first_mode(self) -> str:
        b = self.blob
        at_rest = abs(wrap_pi(self.angle_rad)) < b.rest_angle_rad and abs(self.rate_rad_s) < b.rest_velocity_rad_s
        return "track" if b.plan_steps and at_rest else "swing"

    def _state(self, from_upright: bool) -> list[float]:
        pendulum = wrap_pi(self.angle_rad - math.pi) if from_upright else self.angle_rad
        return [self.arm_rad, pendulum, self.arm_rate_rad_s, self.rate_rad_s, self.output_rad]

    def _track(self) -> float | None:
        b, k = self.blob, self.plan_step
        if k >= b.plan_steps:
            self.mode, self.plan_step = "settle", 0
            return None
        x, planned = self._state(False), b.plan_states[k]
        error = [x[i] - float(planned[i]) for i in range(5)]
        error[1] = wrap_pi(error[1])
        if abs(error[1]) > b.drift_rad:  # off the plan: pump instead (the device does not re-plan)
            self.mode = "swing"
            self.swing_target_rad = self.output_rad
            return None
        self.plan_step += 1
        return float(b.plan_targets[k]) - sum(float(b.plan_gains[k][i]) * error[i] for i in range(5))

    def _settle(self) -> float | None:
        b = self.blob
        x = self._state(True)
        if self.plan_step >= b.settle_steps or abs(x[1]) > b.fall_angle_rad:
            self.mode = "swing"
            self.swing_target_rad = self.output_rad
            return None
        self.plan_step += 1
        return -sum(float(b.settle_gain[i]) * x[i] for i in range(5))

    def _follow(self, target_rad: float) -> float:
        return clamp(target_rad, self.blob.servo_range_rad)

    def _swing_or_balance(self) -> float:
        b = self.blob
        theta = wrap_pi(self.angle_rad - math.pi)
        if self.mode == "swing" and abs(theta) < b.catch_angle_rad and abs(self.rate_rad_s) < b.catch_velocity_rad_s:
            self.mode = "balance"
            self.filtered_rad = clamp(self.arm_rad, b.servo_range_rad)
        elif self.mode == "balance" and abs(theta) > b.fall_angle_rad:
            self.mode = "swing"
            self.swing_target_rad = self.output_rad
        if self.mode == "balance":
            x = [self.arm_rad, theta, self.arm_rate_rad_s, self.rate_rad_s, self.filtered_rad]
            u = -sum(float(b.balance_gain[i]) * x[i] for i in range(5))
            u = clamp(u, b.servo_range_rad)
            c = b.filter_coefficient
            self.filtered_rad = c * self.filtered_rad + (1 - c) * u
            return self.filtered_rad
        self.swing_target_rad = clamp(self.swing_target_rad + self.swing_rate_rad_s() * b.period_s, b.arm_limit_rad)
        return clamp(self.swing_target_rad, b.servo_range_rad)

    def swing_rate_rad_s(self) -> float:
        """The energy law of `pendkit.control.swingup.SwingUpController` with no phase lead."""
        b = self.blob
        w0 = b.natural_frequency_rad_s
        angle, rate = self.angle_rad, self.rate_rad_s / w0
        energy = 0.5 * rate * rate - math.cos(angle)
        missing = b.target_energy - energy
        earlier_angle, earlier_rate = -rate, angle  # a quarter period back
        scale = min(1.0, EARLIER_SWING_RAD / max(math.hypot(earlier_angle, earlier_rate), 1e-12))
        pumps_left = earlier_rate * scale * w0 * math.cos(earlier_angle * scale) > 0
        direction = -1.0 if pumps_left else 1.0
        pumping = direction * b.swing_rate_rad_s * max(-1.0, min(1.0, b.energy_gain * missing))
        return pumping - b.centring_per_s * self.swing_target_rad
