"""Message formats the device writes, and the protocol's shared limits.

Version 1 is the authors' protocol. An observation line is
`S<millis>,<position>,<servo counts>,<omega rev/s>,<acceleration rev/s^2>,<arm velocity counts/s>`; version 2
adds sequence numbers, flags and the echo of the last command (`format_observation_v2`). The host reads them
with `pendkit.telemetry.parse`.
"""

from __future__ import annotations

from pendkit.device.observation import McuObservation
from pendkit.errors import PendkitError

OBSERVATION_V1_FIELDS = 6
OBSERVATION_V2_FIELDS = 10
MAX_UINT32 = 4_294_967_295
MIN_STREAMING_PERIOD_MS = 5  # the `u` command's lower bound


class ProtocolError(PendkitError, ValueError):
    """A payload that does not follow the protocol; the message says why."""


def format_observation_v1(observation: McuObservation) -> str:
    return (f"S{observation.millis},{observation.position_counts},{observation.servo_counts},"
            f"{observation.omega_rev_s:.4f},{observation.acceleration_rev_s2:.4f},"
            f"{observation.arm_velocity_counts_s:.1f}")


def format_observation_v2(observation: McuObservation, observation_seq: int, command_seq: int = 0,
                          echo_host_ms: int = 0) -> str:
    """`R<millis>,<obs seq>,<position>,<servo>,<omega>,<accel>,<arm vel>,<flag bits>,<cmd seq>,<echo ms>`.

    The last command's sequence number and host time come back, so the host can match replies and
    measure the round trip; the flag bits are pendkit.device.logic.FLAG_BITS.
    """
    return (f"R{observation.millis},{observation_seq},{observation.position_counts},{observation.servo_counts},"
            f"{observation.omega_rev_s:.4f},{observation.acceleration_rev_s2:.4f},"
            f"{observation.arm_velocity_counts_s:.1f},{observation.flag_bits},{command_seq},{echo_host_ms}")
