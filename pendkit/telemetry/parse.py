"""The device's observation lines as the host reads them (v1 `S...`, v2 `R...`: `pendkit.device.protocol`).

Decoding is total: anything malformed raises `ProtocolError` with the reason, and nothing else. Numbers
are plain decimals (no `1_00`, exponents, nan or inf), and every value must be one a device can report
(`ReadingLimits`): a rate beyond what the encoder can resolve is a corrupt or forged message, not a reading.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from pendkit.backend_contract import FLAG_BITS
from pendkit.device.observation import McuObservation
from pendkit.device.protocol import (
    MAX_UINT32,
    MIN_STREAMING_PERIOD_MS,
    OBSERVATION_V1_FIELDS,
    OBSERVATION_V2_FIELDS,
    ProtocolError,
)
from pendkit.rig import RigParams

_INTEGER = re.compile(r"-?[0-9]{1,10}")
_DECIMAL = re.compile(r"-?([0-9]{1,12}(\.[0-9]{0,9})?|\.[0-9]{1,9})")


@dataclass(frozen=True)
class ReadingLimits:
    """The largest values a device can report. Between two encoder readings the wrapped difference is at
    most half a turn, so the rate cannot exceed 0.5 rev per reading period; we allow twice that (a reading
    can come early by up to half a period), and derive the acceleration and arm-rate limits the same way."""

    servo_min_counts: int = 0
    servo_max_counts: int = 4095
    reading_period_ms: float = MIN_STREAMING_PERIOD_MS

    @classmethod
    def for_rig(cls, params: RigParams) -> ReadingLimits:
        return cls(params.servo_min_counts, params.servo_max_counts, params.streaming_period_ms)

    @property
    def max_rate_rev_s(self) -> float:
        return 1.0 / (self.reading_period_ms / 1000.0)

    @property
    def max_acceleration_rev_s2(self) -> float:
        return 4.0 * self.max_rate_rev_s / (self.reading_period_ms / 1000.0)

    @property
    def max_arm_rate_counts_s(self) -> float:
        return 2.0 * (self.servo_max_counts - self.servo_min_counts) / (self.reading_period_ms / 1000.0)


ANY_DEVICE = ReadingLimits()


def _check(name: str, value: float, low: float, high: float) -> None:
    if not low <= value <= high:
        raise ProtocolError(f"{name} must be in {low:g}..{high:g}, got {value:g}")


def _integer(field: str, name: str) -> int:
    if not _INTEGER.fullmatch(field):
        raise ProtocolError(f"{name} must be a plain integer, got {field[:16]!r}")
    return int(field)


def _decimal(field: str, name: str) -> float:
    if not _DECIMAL.fullmatch(field):
        raise ProtocolError(f"{name} must be a plain decimal number, got {field[:16]!r}")
    return float(field)


def _text(payload: str | bytes) -> str:
    if isinstance(payload, bytes):
        try:
            payload = payload.decode("ascii")
        except UnicodeDecodeError:
            raise ProtocolError("observation is not ASCII text") from None
    return payload.strip()


def parse_observation_v1(payload: str | bytes, limits: ReadingLimits = ANY_DEVICE) -> McuObservation:
    """Decode one v1 observation line; `ProtocolError` with the reason if it is malformed."""
    text = _text(payload)
    if not text.startswith("S"):
        raise ProtocolError(f"observation must start with 'S', got {text[:12]!r}")
    fields = text[1:].split(",")
    if len(fields) != OBSERVATION_V1_FIELDS:
        raise ProtocolError(f"observation needs {OBSERVATION_V1_FIELDS} fields, got {len(fields)}")
    millis, position, servo = (_integer(f, name) for f, name in zip(fields[:3], ("millis", "position", "servo")))
    omega, accel, arm = (_decimal(f, name) for f, name in zip(fields[3:], ("omega", "acceleration", "arm rate")))
    _check("millis", millis, 0, MAX_UINT32)
    _check("position", position, 0, 1023)
    _check("servo counts", servo, limits.servo_min_counts, limits.servo_max_counts)
    _check("omega (rev/s)", abs(omega), 0, limits.max_rate_rev_s)
    _check("acceleration (rev/s^2)", abs(accel), 0, limits.max_acceleration_rev_s2)
    _check("arm rate (counts/s)", abs(arm), 0, limits.max_arm_rate_counts_s)
    return McuObservation(millis, position, servo, omega, accel, arm, frozenset())


@dataclass(frozen=True)
class ReceivedObservation:
    """A decoded observation line with its v2 bookkeeping (zeros for v1)."""

    observation: McuObservation
    version: int
    observation_seq: int = 0
    command_seq: int = 0
    echo_host_ms: int = 0


def parse_observation(payload: str | bytes, limits: ReadingLimits = ANY_DEVICE) -> ReceivedObservation:
    """Decode a v1 (`S...`) or v2 (`R...`) observation; `ProtocolError` with the reason otherwise."""
    text = _text(payload)
    if text.startswith("S"):
        return ReceivedObservation(parse_observation_v1(text, limits), 1)
    if not text.startswith("R"):
        raise ProtocolError(f"observation must start with 'S' (v1) or 'R' (v2), got {text[:12]!r}")
    fields = text[1:].split(",")
    if len(fields) != OBSERVATION_V2_FIELDS:
        raise ProtocolError(f"v2 observation needs {OBSERVATION_V2_FIELDS} fields, got {len(fields)}")
    obs_seq, flags, cmd_seq, echo = (_integer(fields[k], name) for k, name in
                                     ((1, "observation seq"), (7, "flags"), (8, "command seq"), (9, "echo")))
    _check("flags", flags, 0, sum(FLAG_BITS.values()))
    for name, value in (("observation seq", obs_seq), ("command seq", cmd_seq), ("echo", echo)):
        _check(name, value, 0, MAX_UINT32)
    core = parse_observation_v1("S" + ",".join([fields[0], *fields[2:7]]), limits)
    names = frozenset(name for name, bit in FLAG_BITS.items() if flags & bit)
    return ReceivedObservation(McuObservation(core.millis, core.position_counts, core.servo_counts,
                                              core.omega_rev_s, core.acceleration_rev_s2,
                                              core.arm_velocity_counts_s, names), 2, obs_seq, cmd_seq, echo)
