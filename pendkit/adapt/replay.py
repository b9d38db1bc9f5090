"""Matching on the device's clock: the network taken out of identification.

Every reading a rig sends carries the device's own time and the servo target it applied then. So the
recording of an excitation episode, kept reading by reading, says when each target took effect and where
the pendulum was at each moment, whatever the WiFi did to the messages on the way (a lost command never
moves the servo, and the record shows it; a late reading is placed at the time it was taken). The twin is
then replayed on that clock: its servo given each target when the device applied it, its pendulum read at
the readings' times. What the network adds is measured apart, from the host's own clock: the time from a
command's send to the first reading that shows it.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from pendkit.device.commands import parse_command
from pendkit.device.protocol import ProtocolError
from pendkit.rig import RigParams
from pendkit.sim.model import ARM_JOINT, PENDULUM_JOINT, build_model
from pendkit.telemetry.log import LogRecord, readings_of


@dataclass(frozen=True)
class DeviceTrace:
    """An excitation episode as the device reported it: per reading the device's time (ms; the first reading
    is the one the episode started from, at rest), the pendulum's calibrated angle (rad from hanging,
    unwrapped) and the servo counts applied;
    `loops_ms`: for each change of the target, the time from its send to the first reading that shows it
    (the host's clock; empty when the changes cannot be told apart); `host_ms`: when each reading arrived
    (the host's clock, ms; empty in recordings made before it was kept); `clock_back_ms`: (from, to) device
    times wherever the device's clock went back in the log (the readings after it are not kept above: a device
    that restarted; `pendkit.adapt.recording_checks` refuses such a recording)."""

    ms: tuple[float, ...]
    pendulum_rad: tuple[float, ...]
    servo_counts: tuple[int, ...]
    loops_ms: tuple[float, ...] = ()
    host_ms: tuple[float, ...] = ()
    clock_back_ms: tuple[tuple[float, float], ...] = ()

    def as_dict(self) -> dict:
        return {"ms": list(self.ms), "pendulum_rad": list(self.pendulum_rad), "servo_counts": list(self.servo_counts),
                "loops_ms": list(self.loops_ms), "host_ms": list(self.host_ms),
                "clock_back_ms": [list(pair) for pair in self.clock_back_ms]}

    @classmethod
    def from_dict(cls, record: dict) -> DeviceTrace:
        return cls(tuple(record["ms"]), tuple(record["pendulum_rad"]), tuple(int(c) for c in record["servo_counts"]),
                   tuple(record["loops_ms"]), tuple(record.get("host_ms", ())),
                   tuple((float(a), float(b)) for a, b in record.get("clock_back_ms", ())))

    def changes(self) -> list[tuple[float, int]]:
        """(ms, counts) of each change of the servo target, placed midway between the readings around it."""
        ms, counts = self.ms, self.servo_counts
        return [((ms[k - 1] + ms[k]) / 2, counts[k]) for k in range(1, len(ms)) if counts[k] != counts[k - 1]]


def trace_from_log(records: list[LogRecord], start: int, encoder_counts: int = 1024) -> DeviceTrace | None:
    """The trace of the messages logged from index `start` on, starting from the last reading before it
    (the pendulum at rest); None when there are not two readings to go on."""
    before, during = readings_of(records[:start]), readings_of(records[start:])
    if len(before.millis) == 0 or len(during.millis) == 0:
        return None
    millis = np.concatenate([before.millis[-1:], during.millis])
    kept = np.concatenate([[True], millis[1:] > np.maximum.accumulate(millis)[:-1]])  # a device clock gone back
    went_back = tuple((float(millis[k]), float(millis[k + 1])) for k in np.nonzero(np.diff(millis) < 0)[0])
    host_s = np.concatenate([before.host_time_s[-1:], during.host_time_s])[kept]
    positions = np.concatenate([before.position_counts[-1:], during.position_counts])[kept]
    counts = np.concatenate([before.servo_counts[-1:], during.servo_counts])[kept]
    if len(counts) < 2:
        return None
    angles = np.unwrap(positions * (2 * np.pi / encoder_counts))
    return DeviceTrace(tuple(float(m) for m in millis[kept]), tuple(float(a) for a in angles),
                       tuple(int(c) for c in counts), loops_ms(targets_sent(records, start), host_s, counts),
                       tuple(float(t * 1000) for t in host_s), went_back)


def targets_sent(records: list[LogRecord], start: int) -> list[tuple[float, float]]:
    """(host s, target unit): the target held when the episode started (the last sent before `start`), then
    each one sent from `start` on."""
    sends = [(0.0, 0.0)]
    for index, record in enumerate(records):
        if record.direction != "tx":
            continue
        try:
            command = parse_command(record.payload)
        except ProtocolError:
            continue
        if command.kind == "target":
            sends = [*sends, (record.t_s, command.value)] if index >= start else [(record.t_s, command.value)]
    return sends


def loops_ms(sends: list[tuple[float, float]], host_s: np.ndarray, counts: np.ndarray) -> tuple[float, ...]:
    """ms from each change of the target sent to the first reading (by the host's clock) showing the servo
    moved the same way. Changes and moves are paired in order; a lost send is carried by the next one (the
    host repeats its target every step), which only lengthens that pair. Empty when they do not pair up."""
    changed = [(t, value - before) for (_, before), (t, value) in zip(sends, sends[1:]) if value != before]
    moves = [(host_s[k], counts[k] - counts[k - 1]) for k in range(1, len(counts)) if counts[k] != counts[k - 1]]
    if not changed or len(changed) != len(moves):
        return ()
    if any(np.sign(step) != np.sign(move) for (_, step), (_, move) in zip(changed, moves)):
        return ()
    delays = tuple(float((received - sent) * 1000) for (sent, _), (received, _) in zip(changed, moves))
    return delays if min(delays) >= 0 else ()


def angle_error_rad2(simulated: np.ndarray, recorded: np.ndarray) -> float:
    """Mean of 2 - 2 cos(difference): the squared angle error for small differences, free of the 2 pi wrap
    and smooth at half a turn (lab 09's students write the wrapped square instead)."""
    return float(np.mean(2.0 - 2.0 * np.cos(np.asarray(simulated) - np.asarray(recorded))))


def replay_cost(params: RigParams, pwm_phase_ms: float, recordings) -> float:
    """The mean over `recordings` (each with its `device` trace) of the replayed twin's squared angle error."""
    return float(np.mean([angle_error_rad2(replay(params, pwm_phase_ms, r.device, r.start_servo_target_rad),
                                           r.device.pendulum_rad) for r in recordings]))


def replay(params: RigParams, pwm_phase_ms: float, trace: DeviceTrace, start_servo_rad: float) -> np.ndarray:
    """The twin of `params`, from rest with its arm at `start_servo_rad`, its servo given each target of
    `trace` on the first PWM frame after the device applied it (frames every `pwm_period_ms`, at
    `pwm_phase_ms` past a multiple of it on the device's clock); its pendulum's angle (rad from hanging,
    unwrapped) at each reading's time, read with the rig's calibration offset (its first reading, at rest)."""
    model = build_model(params)
    data = mujoco.MjData(model)
    arm = model.joint(ARM_JOINT).qposadr[0]
    pendulum = model.joint(PENDULUM_JOINT).qposadr[0]
    data.qpos[arm] = data.act[0] = start_servo_rad
    mujoco.mj_forward(model, data)
    tick_ms = params.physics_step_ms
    frame_ms, origin_ms = params.pwm_period_ms, trace.ms[0]
    frame = lambda ms: np.ceil((ms - pwm_phase_ms) / frame_ms) * frame_ms + pwm_phase_ms  # noqa: E731
    events = sorted([(frame(ms) - origin_ms, 0, counts) for ms, counts in trace.changes()]
                    + [(ms - origin_ms, 1, k) for k, ms in enumerate(trace.ms)])  # at one time: the target first
    angles = np.empty(len(trace.ms))
    tick = 0
    for ms, kind, value in events:
        due = int(round(ms / tick_ms))
        if due > tick:
            mujoco.mj_step(model, data, due - tick)
            tick = due
        if kind == 0:
            data.act[0] = params.servo_counts_to_rad(value)
        else:
            angles[value] = data.qpos[pendulum]
    return angles + trace.pendulum_rad[0]
