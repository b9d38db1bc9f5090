"""Reference encoder maths: SSI frames, counts <-> radians, wrap-aware deltas, velocity estimators.

The firmware's C++ core implements the same definitions; `tests/vectors/*.json` proves they agree.
Functions take scalars or numpy arrays.

EMS-22A SSI frame (16 bits, first clocked bit is bit 15):
    bits 15..6  position D9..D0
    bit 5       OCF  offset compensation finished (must be 1)
    bit 4       COF  CORDIC overflow (must be 0)
    bit 3       LIN  linearity alarm (must be 0)
    bit 2       MagINC, bit 1 MagDEC (both 1 = magnet out of range)
    bit 0       even parity over bits 15..1
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pendkit.errors import ConfigError, FrameError

ENCODER_COUNTS = 1024
FRAME_BITS = 16

# Reasons a frame is rejected, in the order they are checked (the firmware uses the same codes).
FRAME_OK = "ok"
FRAME_REASONS = ("ok", "frame_width", "parity", "offset_compensation_not_finished", "cordic_overflow",
                 "linearity_alarm", "magnet_out_of_range")


@dataclass(frozen=True)
class EncoderReading:
    """A decoded, valid frame."""

    position_counts: int
    magnet_moving_closer: bool
    magnet_moving_away: bool


def frame_status(frame: int) -> str:
    """Why `frame` is bad, or "ok"."""
    if not 0 <= frame < (1 << FRAME_BITS):
        return "frame_width"
    if bin(frame).count("1") % 2:
        return "parity"
    if not frame >> 5 & 1:
        return "offset_compensation_not_finished"
    if frame >> 4 & 1:
        return "cordic_overflow"
    if frame >> 3 & 1:
        return "linearity_alarm"
    if frame >> 2 & 1 and frame >> 1 & 1:
        return "magnet_out_of_range"
    return FRAME_OK


def decode_ssi_frame(frame: int) -> EncoderReading:
    """Decode one 16-bit frame; raise `FrameError` naming the failed check."""
    status = frame_status(int(frame))
    if status != FRAME_OK:
        raise FrameError(f"bad encoder frame 0x{int(frame) & 0xFFFFFFFF:04X}: {status}")
    return EncoderReading(position_counts=frame >> 6, magnet_moving_closer=bool(frame >> 2 & 1),
                          magnet_moving_away=bool(frame >> 1 & 1))


def decode_ssi_frames(frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vectorised decode: (positions, reason codes as indices into FRAME_REASONS); 0 means ok."""
    frames = np.asarray(frames, dtype=np.int64)
    reasons = np.zeros(frames.shape, dtype=np.int64)
    bits = [(frames >> k) & 1 for k in range(FRAME_BITS)]
    parity_odd = np.bitwise_xor.reduce(np.stack(bits), axis=0) if frames.size else np.zeros(frames.shape, bool)
    checks = [
        (frames < 0) | (frames >= 1 << FRAME_BITS),
        parity_odd.astype(bool),
        bits[5] == 0,
        bits[4] == 1,
        bits[3] == 1,
        (bits[2] == 1) & (bits[1] == 1),
    ]
    for code, failed in reversed(list(enumerate(checks, start=1))):
        reasons = np.where(failed, code, reasons)
    return (frames >> 6) & (ENCODER_COUNTS - 1), reasons


def encode_ssi_frame(position_counts: int, *, offset_compensated: bool = True, cordic_overflow: bool = False,
                     linearity_alarm: bool = False, magnet_closer: bool = False, magnet_away: bool = False,
                     corrupt_parity: bool = False) -> int:
    """Build a frame as the EMS-22A would send it (for the twin, labs and tests)."""
    if not 0 <= position_counts < ENCODER_COUNTS:
        raise ConfigError(f"position_counts must be in [0, {ENCODER_COUNTS - 1}], got {position_counts}")
    frame = position_counts << 6
    for bit, flag in ((5, offset_compensated), (4, cordic_overflow), (3, linearity_alarm),
                      (2, magnet_closer), (1, magnet_away)):
        frame |= int(flag) << bit
    parity = bin(frame).count("1") % 2
    return frame | (parity ^ int(corrupt_parity))


def counts_to_rad(position_counts, offset_counts: int = 0, counts: int = ENCODER_COUNTS):
    """Raw reading -> pendulum angle from the bottom in [0, 2*pi). The offset is subtracted first."""
    calibrated = np.mod(np.asarray(position_counts) - offset_counts, counts)
    return calibrated * (2 * math.pi / counts)


def rad_to_counts(angle_from_bottom_rad, offset_counts: int = 0, counts: int = ENCODER_COUNTS):
    """Pendulum angle from the bottom -> the raw reading an encoder with `offset_counts` would give.

    Quantises by flooring, as a real absolute encoder reports the sector the shaft is in.
    """
    sector = np.floor(np.asarray(angle_from_bottom_rad) * (counts / (2 * math.pi))).astype(np.int64)
    return np.mod(sector + offset_counts, counts)


def angle_from_upright_rad(angle_from_bottom_rad):
    """Wrap an angle from the bottom to the angle from upright, in [-pi, pi)."""
    return np.mod(np.asarray(angle_from_bottom_rad), 2 * math.pi) - math.pi


def wrapped_rad(angle_rad):
    """An angle (or a difference of two) wrapped into [-pi, pi)."""
    return (np.asarray(angle_rad, dtype=float) + math.pi) % (2 * math.pi) - math.pi


def wrap_delta_counts(new_counts, old_counts, counts: int = ENCODER_COUNTS):
    """new - old, taking the shorter way round the 0/1023 seam. A jump of exactly half a turn is kept."""
    delta = np.asarray(new_counts, dtype=np.int64) - np.asarray(old_counts, dtype=np.int64)
    half = counts // 2
    return np.where(delta > half, delta - counts, np.where(delta < -half, delta + counts, delta))


def wrap_delta(new_counts: int, old_counts: int, counts: int = ENCODER_COUNTS) -> int:
    """Scalar `wrap_delta_counts` for the per-reading hot path (same rule)."""
    delta = new_counts - old_counts
    half = counts // 2
    if delta > half:
        return delta - counts
    if delta < -half:
        return delta + counts
    return delta


def velocity_rev_s(delta_counts, dt_ms, counts: int = ENCODER_COUNTS):
    """Counts moved in `dt_ms` -> revolutions per second (the firmware's delta / dt_ms / 1.024)."""
    return np.asarray(delta_counts, dtype=float) * 1000.0 / (counts * np.asarray(dt_ms, dtype=float))


def finite_difference_rev_s(positions_counts, times_ms, counts: int = ENCODER_COUNTS) -> np.ndarray:
    """Wrap-aware finite-difference velocity between successive readings (length n-1)."""
    positions = np.asarray(positions_counts)
    times = np.asarray(times_ms, dtype=float)
    return velocity_rev_s(wrap_delta_counts(positions[1:], positions[:-1], counts), np.diff(times), counts)


def firmware_velocity(positions_counts, times_ms, window: int = 4, counts: int = ENCODER_COUNTS):
    """The MCU's estimator over a whole log: (mean of the last `window` velocities, acceleration).

    Definitions (shared with the C++ core): the first reading's velocity is 0; the ring buffer starts
    full of zeros; acceleration is the difference of the last two reported means over the interval,
    in rev/s^2, and 0 for the first reading.
    """
    positions = np.asarray(positions_counts)
    times = np.asarray(times_ms, dtype=float)
    if np.any(np.diff(times) <= 0):
        raise ConfigError("times_ms must be strictly increasing")
    raw = np.concatenate([[0.0], finite_difference_rev_s(positions, times, counts)])
    padded = np.concatenate([np.zeros(window - 1), raw])
    mean = np.convolve(padded, np.ones(window), mode="valid") / window
    dt_s = np.concatenate([[1.0], np.diff(times) / 1000.0])
    accel = np.diff(np.concatenate([[0.0], mean])) / dt_s
    accel[0] = 0.0
    return mean, accel


class FirmwareVelocityEstimator:
    """Streaming form of `firmware_velocity`, one reading at a time, as the MCU runs it."""

    def __init__(self, window: int = 4, counts: int = ENCODER_COUNTS) -> None:
        self.window = window
        self.counts = counts
        self.reset()

    def reset(self) -> None:
        self._ring = [0.0] * self.window
        self._index = 0
        self._last_position: int | None = None
        self._last_time_ms = 0.0
        self._last_mean = 0.0

    def update(self, position_counts: int, now_ms: float) -> tuple[float, float]:
        """Add a reading; return (mean velocity rev/s, acceleration rev/s^2)."""
        if self._last_position is None:
            raw, dt_ms = 0.0, None
        else:
            dt_ms = now_ms - self._last_time_ms
            delta = wrap_delta(position_counts, self._last_position, self.counts)
            raw = delta * 1000.0 / (self.counts * dt_ms) if dt_ms > 0 else 0.0
        ring, window = self._ring, self.window
        ring[self._index] = raw
        self._index = (self._index + 1) % window
        mean = sum(ring) / window
        accel = 0.0 if not dt_ms or dt_ms <= 0 else (mean - self._last_mean) * 1000.0 / dt_ms
        self._last_position, self._last_time_ms, self._last_mean = position_counts, now_ms, mean
        return mean, accel


def low_pass(values, alpha: float) -> np.ndarray:
    """First-order low-pass y_k = y_{k-1} + alpha*(x_k - y_{k-1}), starting at y_0 = x_0."""
    if not 0.0 < alpha <= 1.0:
        raise ConfigError(f"alpha must be in (0, 1], got {alpha}")
    values = np.asarray(values, dtype=float)
    out = np.empty_like(values)
    state = values[0] if values.size else 0.0
    for k, value in enumerate(values):
        state += alpha * (value - state)
        out[k] = state
    return out


def low_pass_alpha(cutoff_hz: float, sample_period_ms: float) -> float:
    """Smoothing factor of `low_pass` for a -3 dB cutoff at `cutoff_hz`."""
    if cutoff_hz <= 0 or sample_period_ms <= 0:
        raise ConfigError(f"cutoff_hz and sample_period_ms must be > 0, got {cutoff_hz}, {sample_period_ms}")
    dt_s = sample_period_ms / 1000.0
    tau_s = 1.0 / (2 * math.pi * cutoff_hz)
    return dt_s / (tau_s + dt_s)
