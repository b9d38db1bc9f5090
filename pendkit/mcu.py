"""The firmware's control loop in Python, with time passed in (the C++ core follows the same rules).

Used by the twin's `realistic` fidelity and, later, by the virtual rig. Two independent ticks, as on
the device: the acting tick moves the servo target; the streaming tick reads the encoder, estimates
velocities and produces an observation. Safety stops are applied last, right before actuation, and
no command can override them.
"""

from __future__ import annotations

from dataclasses import dataclass

from pendkit.encoder import FirmwareVelocityEstimator
from pendkit.rig import RigParams
from pendkit.state import STOP, ServoCommand


@dataclass(frozen=True)
class McuObservation:
    """One observation line, in the device's units (the protocol's fields)."""

    millis: int
    position_counts: int
    servo_counts: int
    omega_rev_s: float
    acceleration_rev_s2: float
    arm_velocity_counts_s: float
    flags: frozenset[str]


class McuLogic:
    """Servo command, velocity estimation and safety of one device."""

    def __init__(self, params: RigParams) -> None:
        self.params = params
        self.estimator = FirmwareVelocityEstimator(params.velocity_mean_window, params.encoder_counts)
        self.reset(round(params.servo_centre_counts), 0)

    def reset(self, servo_counts: int, now_ms: int) -> None:
        self.servo_counts = servo_counts
        self.command: ServoCommand = STOP
        self.last_command_ms = now_ms
        self.estimator.reset()
        self.omega_rev_s = 0.0
        self._last_stream_counts: int | None = None
        self._last_stream_servo = servo_counts
        self._last_stream_ms = now_ms
        self.flags: set[str] = set()

    def receive(self, command: ServoCommand, now_ms: int) -> None:
        self.command = command
        self.last_command_ms = now_ms
        self.flags.discard("watchdog")

    def acting_tick(self, now_ms: int) -> int:
        """Advance the servo target by the current command; return the counts to actuate."""
        p = self.params
        if now_ms - self.last_command_ms > p.watchdog_timeout_ms:
            self.flags.add("watchdog")
        if self.command.mode == "continuous":
            wanted = round(p.servo_centre_counts + self.command.target_unit * p.servo_span_counts / 2)
        else:
            wanted = self.servo_counts + self.command.increment_counts
        # Safety last: the watchdog and over-spin stops hold the servo where it is; limits clip it.
        if "watchdog" in self.flags or "overspin" in self.flags:
            wanted = self.servo_counts
        clipped = min(max(wanted, p.servo_min_counts), p.servo_max_counts)
        if clipped != wanted or clipped in (p.servo_min_counts, p.servo_max_counts):
            self.flags.add("arm_limit")
            if self.command.mode == "discrete" and clipped != wanted:
                self.command = STOP  # a discrete action ends at the arm's limit
        else:
            self.flags.discard("arm_limit")
        self.servo_counts = clipped
        return clipped

    def streaming_tick(self, position_counts: int, now_ms: int) -> McuObservation:
        """Read the (calibrated) encoder position and build an observation."""
        p = self.params
        omega, accel = self.estimator.update(position_counts, now_ms)
        self.omega_rev_s = omega
        if abs(omega) > p.overspin_limit_rev_s:
            self.flags.add("overspin")
        else:
            self.flags.discard("overspin")
        dt_ms = now_ms - self._last_stream_ms
        arm_velocity = ((self.servo_counts - self._last_stream_servo) * 1000.0 / dt_ms) if dt_ms > 0 else 0.0
        self._last_stream_servo, self._last_stream_ms = self.servo_counts, now_ms
        return McuObservation(now_ms, position_counts, self.servo_counts, omega, accel, arm_velocity,
                              frozenset(self.flags))


def calibrate_position(raw_counts: int, offset_counts: int, counts: int = 1024) -> int:
    """Raw encoder reading -> position with 0 at the bottom (the firmware's `o<int>` offset)."""
    return (raw_counts - offset_counts) % counts

