"""The twin's physics with the firmware's logic on top, advanced in 5 ms physics ticks.

Shared by the realistic fidelity (which adds latency in memory) and the virtual rig (which speaks MQTT).
Commands are delivered as text with an arrival time and go through the device's one command path
(`DeviceScheduler.receive`) when they arrive; the servo sees its target on 20 ms PWM frames, and every
streaming tick reads the encoder and hands an observation to `emit`. Between those events the physics
runs in one call.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

import mujoco

from pendkit.device.observation import McuObservation
from pendkit.device.scheduler import DeviceScheduler
from pendkit.encoder import encode_ssi_frame
from pendkit.rig import RigParams

ENCODER_FAULTS = (None, "stuck", "garbage")


class TwinDevice:
    """One simulated device: `deliver` commands, `run` ticks, observations to `emit(ms, observation)`."""

    def __init__(self, params: RigParams, model: mujoco.MjModel, data: mujoco.MjData, pendulum_qpos: int,
                 mount_offset_counts: int = 0, protocol: int = 2, residual_offset_counts: int = 0) -> None:
        """`residual_offset_counts`: what the calibration missed (a hanging pendulum reads this many counts)."""
        self.params, self.model, self.data = params, model, data
        self._pendulum_qpos = pendulum_qpos
        self.mount_offset_counts = mount_offset_counts
        self.scheduler = DeviceScheduler(params, protocol)
        self.mcu = self.scheduler.logic
        self.mcu.offset_counts = (mount_offset_counts - residual_offset_counts) % params.encoder_counts
        self._tick_ms = params.physics_step_ms
        self._pwm_ticks = round(params.pwm_period_ms / self._tick_ms)
        self.encoder_fault: str | None = None
        self.reset(round(params.servo_centre_counts))

    def reset(self, servo_counts: int) -> None:
        self.scheduler.reset(servo_counts, 0)
        self.tick = 0
        self._pending: deque[tuple[float, str | bytes]] = deque()
        self._stuck_raw: int | None = None

    @property
    def streaming_on(self) -> bool:
        return self.scheduler.streaming_on

    @property
    def now_ms(self) -> float:
        return self.tick * self._tick_ms

    def deliver(self, arrival_ms: float, command: str | bytes) -> None:
        """A command's text reaching the device at `arrival_ms` (arrivals must not go back in time)."""
        self._pending.append((arrival_ms, command))

    def run(self, ticks: int, emit: Callable[[float, McuObservation], None]) -> None:
        """Advance `ticks` physics ticks, stopping only where the device meets the physics."""
        end = self.tick + ticks
        while self.tick < end:
            tick = self.tick
            self.handle_events_now(emit)
            next_event = min(end, (tick // self._pwm_ticks + 1) * self._pwm_ticks)
            if self.streaming_on:
                next_event = min(next_event, max(tick + 1, math.ceil(self.scheduler.streaming.next_ms / self._tick_ms)))
            if self.mcu.onboard.running:  # the device's own controller reads the encoder on every acting tick
                next_event = min(next_event, max(tick + 1, math.ceil(self.scheduler.acting.next_ms / self._tick_ms)))
            if self._pending:  # a command may change streaming or ask for an observation
                next_event = min(next_event, max(tick + 1, math.ceil(self._pending[0][0] / self._tick_ms)))
            mujoco.mj_step(self.model, self.data, next_event - tick)
            self.tick = next_event

    def handle_events_now(self, emit: Callable[[float, McuObservation], None]) -> None:
        """What the device does at the current tick without stepping the physics: commands that have arrived,
        acting ticks, the PWM frame, a due reading. Safe to call again at the same tick (nothing repeats);
        a real-time rig calls it after `run` so a reading due now leaves now, not a tick later."""
        now_ms = self.tick * self._tick_ms
        at_pwm = self.tick % self._pwm_ticks == 0
        arrived = bool(self._pending) and self._pending[0][0] <= now_ms
        acting_now = self.mcu.onboard.running and self.scheduler.acting.next_ms <= now_ms
        if at_pwm or arrived or acting_now or self._stream_due(now_ms):
            self._catch_up(now_ms)
        if at_pwm:
            self.data.act[0] = self.params.servo_counts_to_rad(self.mcu.servo_counts)
        if self.scheduler.streaming_due(now_ms):
            emit(now_ms, self._read_and_stream())

    def _stream_due(self, now_ms: float) -> bool:
        scheduler = self.scheduler
        return (scheduler.streaming_on and scheduler.streaming.next_ms <= now_ms) or scheduler.observe_once

    def _catch_up(self, now_ms: float) -> None:
        """Acting ticks and command arrivals up to now, in time order (a command before a tick at the
        same moment). Commands act on arrival, as in the firmware's message callback."""
        scheduler = self.scheduler
        while True:
            acting_ms = scheduler.acting.next_ms if scheduler.acting.next_ms <= now_ms else math.inf
            command_ms = self._pending[0][0] if self._pending and self._pending[0][0] <= now_ms else math.inf
            if acting_ms == math.inf and command_ms == math.inf:
                return
            if command_ms <= acting_ms:
                arrival_ms, payload = self._pending.popleft()
                scheduler.receive(payload, int(math.ceil(arrival_ms / self._tick_ms) * self._tick_ms))
            else:
                scheduler.acting_due(acting_ms)
                raw = self._onboard_reading() if self.mcu.onboard.running else None
                self.mcu.acting_tick(int(acting_ms), raw)

    def raw_encoder_counts(self) -> int:
        counts = self.params.encoder_counts
        angle = self.data.qpos[self._pendulum_qpos]
        return (math.floor(angle * counts / (2 * math.pi)) + self.mount_offset_counts) % counts

    def _onboard_reading(self) -> int:
        """The encoder as the controller reads it on an acting tick (a stuck encoder repeats itself)."""
        if self.encoder_fault == "stuck" and self._stuck_raw is not None:
            return self._stuck_raw
        return self.raw_encoder_counts()

    def _read_and_stream(self) -> McuObservation:
        raw, now_ms = self.raw_encoder_counts(), int(self.now_ms)
        if self.encoder_fault is None:
            return self.mcu.streaming_tick(raw, now_ms)
        if self.encoder_fault == "stuck":  # a seized shaft or a frozen chip: the same valid frame forever
            self._stuck_raw = raw if self._stuck_raw is None else self._stuck_raw
            return self.mcu.streaming_frame(encode_ssi_frame(self._stuck_raw), now_ms)
        return self.mcu.streaming_frame(encode_ssi_frame(raw, corrupt_parity=True), now_ms)  # "garbage"
