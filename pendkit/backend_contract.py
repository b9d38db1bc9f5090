"""Plain records exchanged between a backend (twin or rig) and the env.

A backend turns `ServoCommand`s into `RigState`s; the env computes observations and rewards from
`RigState` alone, so the task logic is testable without MuJoCo or a broker.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, NamedTuple

# The one flag table: the bits a v2 observation carries (firmware/lib/pendcore/src/device.h mirrors it).
FLAG_BITS = {"arm_limit": 1, "overspin": 2, "stuck_encoder": 4, "watchdog": 8, "frame_error": 16}
SAFETY_FLAGS = tuple(name for name in FLAG_BITS if name != "frame_error")  # frame_error marks one reading


@dataclass(frozen=True)
class ServoCommand:
    """What the host asks of the device, in the firmware's own terms.

    mode "discrete": move the servo target by `increment_counts` on every acting tick (0 = stop).
    mode "continuous": hold the servo target at `target_unit` in [-1, 1] (leftmost..rightmost).
    `action`: the discrete action's index (0 stop .. 4 right fast), which is what goes on the wire.
    """

    mode: Literal["discrete", "continuous"]
    increment_counts: int = 0
    target_unit: float = 0.0
    action: int | None = None


STOP = ServoCommand("discrete", 0, action=0)


class RigState(NamedTuple):
    """One observation of the rig as the host sees it. Angles in radians, rates per second.

    `pendulum_angle_rad` is measured from the bottom in [0, 2*pi) as the encoder reports it.
    `arm_angle_rad` is the best knowledge of the arm: the true angle on an ideal twin, the servo command
    on a hobby servo (which has no position feedback). A NamedTuple: cheap to make on every step.
    """

    time_s: float
    pendulum_angle_rad: float
    pendulum_velocity_rad_s: float
    pendulum_acceleration_rad_s2: float
    arm_angle_rad: float
    arm_velocity_rad_s: float
    servo_target_rad: float
    observation_age_s: float = 0.0
    time_since_action_s: float = 0.0
    encoder_counts: int | None = None
    safety_flags: frozenset[str] = frozenset()


@dataclass(frozen=True)
class BackendTiming:
    """What a backend tells its controllers about time, in seconds: the mean step, the mean time from
    sending a command to the servo acting on it, and from an encoder reading to the host having it
    (beyond the age each state reports). `firmware_readings`: the readings are the device's estimates
    (quantised, averaged, the servo command for the arm), so an observer is worth running."""

    step_s: float
    command_delay_s: float = 0.0
    reading_delay_s: float = 0.0
    firmware_readings: bool = False

    @property
    def loop_delay_s(self) -> float:
        """From a reading's moment to the servo acting on the command it led to: both ways together."""
        return self.command_delay_s + self.reading_delay_s

    @property
    def design_delay_s(self) -> float:
        """The delay a controller designs for: with the firmware's readings an observer estimates the
        present, so only the command's way remains; otherwise the whole loop."""
        return self.command_delay_s if self.firmware_readings else self.loop_delay_s
