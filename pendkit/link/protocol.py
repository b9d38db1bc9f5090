"""Message formats shared by the host and the device.

Version 1 is the authors' protocol. An observation line is
`S<millis>,<position>,<servo counts>,<omega rev/s>,<acceleration rev/s^2>,<arm velocity counts/s>`.
Decoding is total: anything malformed raises `ProtocolError` with the reason, and nothing else.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pendkit.errors import PendkitError
from pendkit.mcu import FLAG_BITS, McuObservation
from pendkit.rig import RigParams
from pendkit.state import ServoCommand

OBSERVATION_V1_FIELDS = 6


class ProtocolError(PendkitError, ValueError):
    """A payload that does not follow the protocol; the message says why."""


def format_observation_v1(observation: McuObservation) -> str:
    return (f"S{observation.millis},{observation.position_counts},{observation.servo_counts},"
            f"{observation.omega_rev_s:.4f},{observation.acceleration_rev_s2:.4f},"
            f"{observation.arm_velocity_counts_s:.1f}")


def _text(payload: str | bytes) -> str:
    if isinstance(payload, bytes):
        try:
            payload = payload.decode("ascii")
        except UnicodeDecodeError:
            raise ProtocolError("observation is not ASCII text") from None
    return payload.strip()


def parse_observation_v1(payload: str | bytes) -> McuObservation:
    """Decode one v1 observation line; `ProtocolError` with the reason if it is malformed."""
    text = _text(payload)
    if not text.startswith("S"):
        raise ProtocolError(f"observation must start with 'S', got {text[:12]!r}")
    fields = text[1:].split(",")
    if len(fields) != OBSERVATION_V1_FIELDS:
        raise ProtocolError(f"observation needs {OBSERVATION_V1_FIELDS} fields, got {len(fields)}")
    try:
        millis, position, servo = (int(f) for f in fields[:3])
        omega, accel, arm = (float(f) for f in fields[3:])
    except ValueError:
        raise ProtocolError(f"observation has a field that is not a number: {text[:60]!r}") from None
    if not 0 <= position < 1024:
        raise ProtocolError(f"position must be in 0..1023, got {position}")
    if millis < 0 or servo < 0 or not all(math.isfinite(v) for v in (omega, accel, arm)):
        raise ProtocolError(f"observation has an out-of-range value: {text[:60]!r}")
    return McuObservation(millis, position, servo, omega, accel, arm, frozenset())


def format_command_v1(command: ServoCommand, params: RigParams) -> str:
    """A command as the authors' firmware takes it: a/s/d/f/g (fast left .. fast right) or b<target>."""
    if command.mode == "continuous":
        return f"b{command.target_unit:.4f}"
    letters = {0: "d", -params.discrete_slow_step_counts: "s", -params.discrete_fast_step_counts: "a",
               params.discrete_slow_step_counts: "f", params.discrete_fast_step_counts: "g"}
    if command.increment_counts not in letters:
        raise ProtocolError(f"v1 has no letter for an increment of {command.increment_counts} counts")
    return letters[command.increment_counts]


OBSERVATION_V2_FIELDS = 10


def format_observation_v2(observation: McuObservation, observation_seq: int, command_seq: int = 0,
                          echo_host_ms: int = 0) -> str:
    """`R<millis>,<obs seq>,<position>,<servo>,<omega>,<accel>,<arm vel>,<flag bits>,<cmd seq>,<echo ms>`.

    The last command's sequence number and host time come back, so the host can match replies and
    measure the round trip; the flag bits are pendkit.mcu.FLAG_BITS.
    """
    return (f"R{observation.millis},{observation_seq},{observation.position_counts},{observation.servo_counts},"
            f"{observation.omega_rev_s:.4f},{observation.acceleration_rev_s2:.4f},"
            f"{observation.arm_velocity_counts_s:.1f},{observation.flag_bits},{command_seq},{echo_host_ms}")


@dataclass(frozen=True)
class ReceivedObservation:
    """A decoded observation line with its v2 bookkeeping (zeros for v1)."""

    observation: McuObservation
    version: int
    observation_seq: int = 0
    command_seq: int = 0
    echo_host_ms: int = 0


def parse_observation(payload: str | bytes) -> ReceivedObservation:
    """Decode a v1 (`S...`) or v2 (`R...`) observation; `ProtocolError` with the reason otherwise."""
    text = _text(payload)
    if text.startswith("S"):
        return ReceivedObservation(parse_observation_v1(text), 1)
    if not text.startswith("R"):
        raise ProtocolError(f"observation must start with 'S' (v1) or 'R' (v2), got {text[:12]!r}")
    fields = text[1:].split(",")
    if len(fields) != OBSERVATION_V2_FIELDS:
        raise ProtocolError(f"v2 observation needs {OBSERVATION_V2_FIELDS} fields, got {len(fields)}")
    try:
        millis, obs_seq = int(fields[0]), int(fields[1])
        flags, cmd_seq, echo = int(fields[7]), int(fields[8]), int(fields[9])
    except ValueError:
        raise ProtocolError(f"v2 observation has a field that is not a number: {text[:60]!r}") from None
    if not 0 <= flags < 32 or min(millis, obs_seq, cmd_seq, echo) < 0:
        raise ProtocolError(f"v2 observation has an out-of-range value: {text[:60]!r}")
    core = parse_observation_v1("S" + ",".join([fields[0], *fields[2:7]]))
    names = frozenset(name for name, bit in FLAG_BITS.items() if flags & bit)
    return ReceivedObservation(McuObservation(core.millis, core.position_counts, core.servo_counts,
                                              core.omega_rev_s, core.acceleration_rev_s2,
                                              core.arm_velocity_counts_s, names), 2, obs_seq, cmd_seq, echo)
