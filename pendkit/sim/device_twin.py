"""The twin's physics with the firmware's logic on top, advanced in 5 ms physics ticks.

Shared by the realistic fidelity (which adds latency in memory) and the virtual rig (which speaks MQTT).
Commands are delivered with an arrival time and applied on the next acting tick, the servo sees its
target on 20 ms PWM frames, and every streaming tick reads the encoder and hands an observation to
`emit`. Between those events the physics runs in one call.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

import mujoco

from pendkit.encoder import encode_ssi_frame
from pendkit.link.commands import DeviceCommand
from pendkit.mcu import McuLogic, McuObservation
from pendkit.rig import RigParams
from pendkit.state import ServoCommand

Delivery = ServoCommand | DeviceCommand
ENCODER_FAULTS = (None, "stuck", "garbage")


class TwinDevice:
    """One simulated device: `deliver` commands, `run` ticks, observations to `emit(ms, observation)`."""

    def __init__(self, params: RigParams, model: mujoco.MjModel, data: mujoco.MjData, pendulum_qpos: int,
                 mount_offset_counts: int = 0) -> None:
        self.params, self.model, self.data = params, model, data
        self._pendulum_qpos = pendulum_qpos
        self.mount_offset_counts = mount_offset_counts
        self.mcu = McuLogic(params)
        self.mcu.offset_counts = mount_offset_counts  # a calibrated device
        self._tick_ms = params.physics_step_ms
        self._pwm_ticks = round(params.pwm_period_ms / self._tick_ms)
        self.acting_ticks = round(params.acting_period_ms / self._tick_ms)
        self.streaming_ticks = round(params.streaming_period_ms / self._tick_ms)
        self.encoder_fault: str | None = None
        self.reset(round(params.servo_centre_counts))

    def reset(self, servo_counts: int) -> None:
        self.mcu.reset(servo_counts, 0)
        self.tick = 0
        self._next_acting_tick = 0
        self._pending: deque[tuple[float, Delivery]] = deque()
        self.streaming_on = True
        self._observe_once = False
        self._stuck_raw: int | None = None

    @property
    def now_ms(self) -> float:
        return self.tick * self._tick_ms

    def deliver(self, arrival_ms: float, command: Delivery) -> None:
        """A command reaching the device at `arrival_ms` (arrivals must not go back in time)."""
        self._pending.append((arrival_ms, command))

    def run(self, ticks: int, emit: Callable[[float, McuObservation], None]) -> None:
        """Advance `ticks` physics ticks, stopping only where the device meets the physics."""
        data, model, mcu = self.data, self.model, self.mcu
        end = self.tick + ticks
        while self.tick < end:
            tick = self.tick
            now_ms = tick * self._tick_ms
            at_pwm = tick % self._pwm_ticks == 0
            arrived = bool(self._pending) and self._pending[0][0] <= now_ms
            if at_pwm or arrived or self._stream_due(tick):
                self._catch_up(tick)
            if at_pwm:
                data.act[0] = self.params.servo_counts_to_rad(mcu.servo_counts)
            if self._stream_due(tick):
                self._observe_once = False
                emit(now_ms, self._read_and_stream())
            next_event = min(end, (tick // self._pwm_ticks + 1) * self._pwm_ticks)
            if self.streaming_on:
                next_event = min(next_event, (tick // self.streaming_ticks + 1) * self.streaming_ticks)
            if self._pending:  # a command may change streaming or ask for an observation
                next_event = min(next_event, max(tick + 1, math.ceil(self._pending[0][0] / self._tick_ms)))
            mujoco.mj_step(model, data, next_event - tick)
            self.tick = next_event

    def _stream_due(self, tick: int) -> bool:
        return (self.streaming_on and tick % self.streaming_ticks == 0) or self._observe_once

    def _catch_up(self, up_to_tick: int) -> None:
        """Acting ticks and command arrivals up to now, in time order (a command before a tick at the
        same moment). Commands act on arrival, as in the firmware's message callback."""
        now_ms = up_to_tick * self._tick_ms
        while True:
            acting_ms = self._next_acting_tick * self._tick_ms if self._next_acting_tick <= up_to_tick else math.inf
            command_ms = self._pending[0][0] if self._pending and self._pending[0][0] <= now_ms else math.inf
            if acting_ms == math.inf and command_ms == math.inf:
                return
            if command_ms <= acting_ms:
                self._apply(self._pending.popleft()[1], int(math.ceil(command_ms / self._tick_ms) * self._tick_ms))
            else:
                self.mcu.acting_tick(acting_ms)
                self._next_acting_tick += self.acting_ticks

    def _apply(self, command: Delivery, now_ms: int) -> None:
        if isinstance(command, ServoCommand):
            self.mcu.receive(command, now_ms)
            return
        kind, value = command.kind, command.value
        if kind == "stream_on":
            self.streaming_on = True
        elif kind == "stream_off":
            self.streaming_on = False
        elif kind == "observe_once":
            self._observe_once = True
        elif kind == "streaming_period":
            self.streaming_ticks = max(1, round(value / self._tick_ms))
        elif kind == "acting_period":
            self.acting_ticks = max(1, round(value / self._tick_ms))
        else:
            self.mcu.handle(command, now_ms)

    def raw_encoder_counts(self) -> int:
        counts = self.params.encoder_counts
        angle = self.data.qpos[self._pendulum_qpos]
        return (math.floor(angle * counts / (2 * math.pi)) + self.mount_offset_counts) % counts

    def _read_and_stream(self) -> McuObservation:
        raw, now_ms = self.raw_encoder_counts(), int(self.now_ms)
        if self.encoder_fault is None:
            return self.mcu.streaming_tick(raw, now_ms)
        if self.encoder_fault == "stuck":  # a seized shaft or a frozen chip: the same valid frame forever
            self._stuck_raw = raw if self._stuck_raw is None else self._stuck_raw
            return self.mcu.streaming_frame(encode_ssi_frame(self._stuck_raw), now_ms)
        return self.mcu.streaming_frame(encode_ssi_frame(raw, corrupt_parity=True), now_ms)  # "garbage"
