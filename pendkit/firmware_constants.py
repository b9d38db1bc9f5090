"""The firmware's constants, written from `RigParams` (the one source of truth) as a C++ header.

`pendkit firmware-header > firmware/lib/pendcore/src/rig_constants.h` regenerates it; a test
fails when the committed header and RigParams disagree. `--preset mks-x5-hbl550` writes a header for a rig
built with another servo (flash that rig with it, and give the host the same preset).
"""

from __future__ import annotations

from pendkit.device.logic import STUCK_BAD_FRAMES, STUCK_TRAVEL_COUNTS
from pendkit.device.physical_ranges import MODEL_RANGES, SWING_UP_RANGES
from pendkit.device.swingup_blob import SCALARS
from pendkit.rig import RigParams

FLOAT32_MAX = 3.4028234663852886e38


def render_header(params: RigParams | None = None) -> str:
    p = params or RigParams()
    values = [
        ("kEncoderCounts", "int32_t", p.encoder_counts, "positions per turn (EMS-22A)"),
        ("kEncoderOffsetCounts", "int32_t", p.encoder_offset_counts, "raw reading with the pendulum hanging"),
        ("kServoMinCounts", "int32_t", p.servo_min_counts, f"PCA9685 counts at -{p.servo_range_deg:g} deg"),
        ("kServoMaxCounts", "int32_t", p.servo_max_counts, f"PCA9685 counts at +{p.servo_range_deg:g} deg"),
        ("kServoCentreCounts", "double", p.servo_centre_counts, "counts at 0 deg"),
        ("kServoSpanCounts", "int32_t", p.servo_span_counts, "max - min"),
        ("kServoRangeRad", "double", p.servo_range_rad, "arm angle at either end of the span"),
        ("kSlowStepCounts", "int32_t", p.discrete_slow_step_counts, "discrete slow step per acting tick"),
        ("kFastStepCounts", "int32_t", p.discrete_fast_step_counts, "discrete fast step per acting tick"),
        ("kPwmPeriodMs", "int32_t", int(p.pwm_period_ms), "servo PWM period (50 Hz)"),
        ("kPwmResolutionCounts", "int32_t", p.pwm_resolution_counts, "PCA9685 counts per PWM period"),
        ("kStreamingPeriodMs", "int32_t", int(p.streaming_period_ms), "observation period"),
        ("kActingPeriodMs", "int32_t", int(p.acting_period_ms), "acting period"),
        ("kVelocityWindow", "int32_t", p.velocity_mean_window, "velocities averaged"),
        ("kOverspinLimitRevS", "double", p.overspin_limit_rev_s, "hold the servo above this spin"),
        ("kWatchdogTimeoutMs", "double", p.watchdog_timeout_ms, "hold the servo without commands"),
        ("kStuckBadFrames", "int32_t", STUCK_BAD_FRAMES, "bad SSI frames in a row: stuck encoder"),
        ("kStuckTravelCounts", "int32_t", STUCK_TRAVEL_COUNTS, "servo travel without an encoder change: stuck"),
    ]
    lines = ["// Generated from pendkit.rig.RigParams by pendkit/firmware_constants.py. Do not edit.",
             f"// Rig: {p.servo_name}.", "#pragma once", "", "#include <cstdint>", "", "namespace pend {", ""]
    for name, kind, value, comment in values:
        literal = repr(float(value)) if kind == "double" else str(int(value))
        lines.append(f"constexpr {kind} {name} = {literal};  // {comment}")
    lines += ["", *model_range_lines(), "", "}  // namespace pend", ""]
    return "\n".join(lines)


def model_range_lines() -> list[str]:
    """An observer model's physical ranges, in MODEL_FIELDS' order (pendkit.device.physical_ranges: the kit's
    rig with margins, whatever the servo the header is written for), so both parsers refuse the same blobs."""

    unbounded = (-FLOAT32_MAX, FLOAT32_MAX)  # a controller's gains: any finite float
    swing_up = [SWING_UP_RANGES.get(name, unbounded) for name in SCALARS]
    return ["// An observer model's physical ranges (pendkit/device/physical_ranges.py), in MODEL_FIELDS' order:",
            "// arm, pendulum and long-axis inertias, coupling, gravity torque, pendulum and arm damping, kp, kv,",
            "// stall torque, servo range",
            *_array("kObserverModelMin", [low for low, _ in MODEL_RANGES.values()]),
            *_array("kObserverModelMax", [high for _, high in MODEL_RANGES.values()]),
            "// A swing-up blob's scalars' ranges, in SCALARS' order (pendkit/device/swingup_blob.py): its model's",
            "// terms physical, its gains any finite float",
            *_array("kSwingUpScalarMin", [low for low, _ in swing_up]),
            *_array("kSwingUpScalarMax", [high for _, high in swing_up])]


def _array(name: str, values: list[float]) -> list[str]:
    """A constexpr array of doubles, a few to a line."""
    literals = [repr(float(value)) for value in values]
    rows = [", ".join(literals[k:k + 4]) for k in range(0, len(literals), 4)]
    return [f"constexpr double {name}[{len(values)}] = {{", *[f"    {row}," for row in rows], "};"]
