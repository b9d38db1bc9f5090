"""The delays between a choice and the servo, and between the pendulum and a reading: worked out here, once,
from a rig's `RigParams` and its network's latency, for every backend, design and fit that needs them.

The device's clocks (docs/protocol.md): commands act on arrival and move the servo target on the next acting
tick; the servo takes the target in force on its next PWM frame, a clock of its own; a reading leaves on a
streaming tick. Each wait is half its period on average, as on a rig. (The twin's frames still start with its
acting ticks, so there a target waits about half as long: tests/device/test_device_timing.py.)"""

from __future__ import annotations

from pendkit.backend_contract import BackendTiming


def acting_wait_ms(params) -> float:
    """A host's command waits for the next acting tick: half a tick on average."""
    return params.acting_period_ms / 2


def pwm_wait_ms(params) -> float:
    """A target set on an acting tick waits for the servo's next PWM frame: half a frame on average."""
    return params.pwm_period_ms / 2


def streaming_wait_ms(params, streaming_period_ms: float | None = None) -> float:
    """A reading asked for waits for the next streaming tick: half a period on average."""
    return (params.streaming_period_ms if streaming_period_ms is None else streaming_period_ms) / 2


def device_command_delay_s(params) -> float:
    """From a controller on the device choosing a target (on an acting tick) to the servo taking it."""
    return pwm_wait_ms(params) / 1000.0


def host_command_delay_ms(params, latency_ms: float) -> float:
    """From the host sending a command to the servo taking it: the trip, an acting tick, a PWM frame."""
    return latency_ms + acting_wait_ms(params) + pwm_wait_ms(params)


def host_timing(params, step_s: float, command_latency_ms: float, reading_latency_ms: float) -> BackendTiming:
    """What a backend whose readings come from the device's firmware (the realistic twin, a rig) tells its
    controllers: a command's delay (kept below the step) and a reading's age."""
    command_s = host_command_delay_ms(params, command_latency_ms) / 1000
    return BackendTiming(step_s, min(command_s, 0.9 * step_s), reading_latency_ms / 1000, firmware_readings=True)


def device_timing(params) -> BackendTiming:
    """What a controller on the device designs for: its own target's wait for the PWM frame, and readings of
    the present (it reads the encoder itself)."""
    return BackendTiming(params.control_step_ms / 1000.0, device_command_delay_s(params), 0.0,
                         firmware_readings=True)


def round_trip_ms(params, latency_ms: float, streaming_period_ms: float | None = None) -> float:
    """From the host sending a command to a reading that shows it: both trips (alike), the acting tick's wait
    and the next reading's."""
    return 2 * latency_ms + acting_wait_ms(params) + streaming_wait_ms(params, streaming_period_ms)


def one_way_latency_ms(round_trip_median_ms: float, params, streaming_period_ms: float | None = None) -> float:
    """The inverse of `round_trip_ms`: the one-way latency (both ways alike) that gives that round trip."""
    waits_ms = round_trip_ms(params, 0.0, streaming_period_ms)
    return max(0.0, (round_trip_median_ms - waits_ms) / 2)
