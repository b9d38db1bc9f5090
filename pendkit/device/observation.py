"""One observation as the device makes it (the protocol's fields, in the device's units) and what the host
knows from it in SI units: shared by the device's loop, the twin's backend, the rig link and the device's
own policy runtime."""

from __future__ import annotations

import math
from dataclasses import dataclass

from pendkit.backend_contract import FLAG_BITS, RigState
from pendkit.rig import RigParams


@dataclass(frozen=True)
class McuObservation:
    """One observation, in the device's units (the protocol's fields)."""

    millis: int
    position_counts: int
    servo_counts: int
    omega_rev_s: float
    acceleration_rev_s2: float
    arm_velocity_counts_s: float
    flags: frozenset[str]

    def __init__(self, millis: int, position_counts: int, servo_counts: int, omega_rev_s: float,
                 acceleration_rev_s2: float, arm_velocity_counts_s: float, flags: frozenset[str]) -> None:
        # Made on every streaming tick: filled in one go, where a frozen dataclass's own __init__ sets each
        # field through object.__setattr__ (about twice the time)
        self.__dict__.update(millis=millis, position_counts=position_counts, servo_counts=servo_counts,
                             omega_rev_s=omega_rev_s, acceleration_rev_s2=acceleration_rev_s2,
                             arm_velocity_counts_s=arm_velocity_counts_s, flags=flags)

    @property
    def flag_bits(self) -> int:
        return sum(FLAG_BITS[f] for f in self.flags)


def observation_to_state(observation: McuObservation, params: RigParams, observation_age_s: float,
                         time_since_action_s: float, servo_target_counts: int | None = None) -> RigState:
    """What the host knows from one observation, in SI units. A hobby servo reports no position, so the
    arm angle is the servo command; the target is the device's current one when known."""
    target = observation.servo_counts if servo_target_counts is None else servo_target_counts
    to_rad = params.servo_counts_to_rad
    # RigState's fields in order (positional: made on every step)
    return RigState(observation.millis / 1000.0,  # time_s
                    observation.position_counts * (2 * math.pi / params.encoder_counts),  # pendulum_angle_rad
                    observation.omega_rev_s * 2 * math.pi,  # pendulum_velocity_rad_s
                    observation.acceleration_rev_s2 * 2 * math.pi,  # pendulum_acceleration_rad_s2
                    to_rad(observation.servo_counts),  # arm_angle_rad
                    observation.arm_velocity_counts_s * params.servo_rad_per_count,  # arm_velocity_rad_s
                    to_rad(target),  # servo_target_rad
                    observation_age_s, time_since_action_s, observation.position_counts, observation.flags)
