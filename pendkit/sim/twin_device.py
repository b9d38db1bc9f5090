"""The twin's physics with the firmware's logic on top, advanced in 5 ms physics ticks.

Shared by the realistic fidelity (which adds latency in memory) and the virtual rig (which speaks MQTT).
Commands are delivered as text with an arrival time and go through the device's one command path
(`DeviceScheduler.receive`) when they arrive; the servo sees its target on 20 ms PWM frames, and every
streaming tick reads the encoder and hands an observation to `emit`. Between those events the physics
runs in one call. An action, a target or a heartbeat only sets what the next PWM frame carries, so its arrival
is no such event: it is taken at the next one, in time order with the acting ticks, with the same result.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

import mujoco

from pendkit.device.commands import parse_command
from pendkit.device.observation import McuObservation
from pendkit.device.protocol import ProtocolError
from pendkit.device.scheduler import DeviceScheduler
from pendkit.encoder import encode_ssi_frame
from pendkit.rig import RigParams

ENCODER_FAULTS = (None, "stuck", "garbage")
WAITS_FOR_NEXT_EVENT = frozenset(("action", "target", "heartbeat"))


class TwinDevice:
    """One simulated device: `deliver` commands, `run` ticks, observations to `emit(ms, observation)`."""

    def __init__(self, params: RigParams, model: mujoco.MjModel, data: mujoco.MjData, pendulum_qpos: int,
                 mount_offset_counts: int = 0, protocol: int = 2, residual_offset_counts: int = 0) -> None:
        """`residual_offset_counts`: what the calibration missed (a hanging pendulum reads this many counts)."""
        self.params, self.model, self.data = params, model, data
        # MjData hands out a new array view on every attribute read: the two the ticks use, taken once
        self._qpos, self._act = data.qpos, data.act
        self._pendulum_qpos = pendulum_qpos
        self.mount_offset_counts = mount_offset_counts
        self.scheduler = DeviceScheduler(params, protocol)
        self.mcu = self.scheduler.logic
        self.mcu.offset_counts = (mount_offset_counts - residual_offset_counts) % params.encoder_counts
        self._tick_ms = params.physics_step_ms
        self._pwm_ticks = round(params.pwm_period_ms / self._tick_ms)
        # The servo's frames start with the acting ticks, so a target set on a tick waits 0 or 10 ms (about 5
        # on average) where a rig's free-running frames make it half a frame (pendkit.timing). Frames half an
        # acting tick out of step would agree with a rig, but cost the realistic policies trained on this
        # twin (r-dqn-levels-realistic held 7 of 10 rule starts instead of 10): kept until they are retrained.
        self._pwm_phase_ticks = 0
        self.encoder_fault: str | None = None
        self.reset(round(params.servo_centre_counts))

    def __getstate__(self) -> dict:
        """Pickled without the cached views (a copy's views must be of its own MjData)."""
        return {k: v for k, v in self.__dict__.items() if k not in ("_qpos", "_act")}

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._qpos, self._act = self.data.qpos, self.data.act

    def reset(self, servo_counts: int) -> None:
        self.scheduler.reset(servo_counts, 0)
        self.tick = 0
        self._pending: deque[tuple[float, object, bool]] = deque()  # (arrival ms, command, stops the physics)
        self._stuck_raw: int | None = None

    @property
    def streaming_on(self) -> bool:
        return self.scheduler.streaming_on

    @property
    def now_ms(self) -> float:
        return self.tick * self._tick_ms

    def deliver(self, arrival_ms: float, command: str | bytes) -> None:
        """A command's text reaching the device at `arrival_ms` (arrivals must not go back in time)."""
        if type(command) is str:
            try:
                parsed = parse_command(command)
                self._pending.append((arrival_ms, parsed, parsed.kind not in WAITS_FOR_NEXT_EVENT))
                return
            except ProtocolError:
                pass  # the device counts it as it arrives
        self._pending.append((arrival_ms, command, True))

    def run(self, ticks: int, emit: Callable[[float, McuObservation], None]) -> None:
        """Advance `ticks` physics ticks, stopping only where the device meets the physics."""
        # The realistic twin's and the virtual rig's hot loop: what it reads often is held in locals.
        tick = self.tick
        end = tick + ticks
        scheduler, onboard, pending = self.scheduler, self.mcu.onboard, self._pending
        streaming, acting = scheduler.streaming, scheduler.acting
        tick_ms, pwm_ticks, phase = self._tick_ms, self._pwm_ticks, self._pwm_phase_ticks
        handle_events_now, mj_step, model, data = self.handle_events_now, mujoco.mj_step, self.model, self.data
        ceil = math.ceil
        while tick < end:
            handle_events_now(emit)
            next_event = ((tick - phase) // pwm_ticks + 1) * pwm_ticks + phase  # the next PWM frame
            if next_event > end:
                next_event = end
            soonest = tick + 1
            if scheduler.streaming_on:
                due = ceil(streaming.next_ms / tick_ms)
                next_event = min(next_event, due if due > soonest else soonest)
            if onboard.running:  # the device's own controller reads the encoder on every acting tick
                due = ceil(acting.next_ms / tick_ms)
                next_event = min(next_event, due if due > soonest else soonest)
            for arrival_ms, _, stops in pending:  # a command may change streaming or ask for an observation
                if stops:
                    due = ceil(arrival_ms / tick_ms)
                    next_event = min(next_event, due if due > soonest else soonest)
                    break
            mj_step(model, data, next_event - tick)
            self.tick = tick = next_event
        # commands after the last event, taken at their arrival ticks as a stop there would have taken them
        while pending and ceil(pending[0][0] / tick_ms) < end:
            self._take_commands_and_acting_ticks(ceil(pending[0][0] / tick_ms) * tick_ms)

    def handle_events_now(self, emit: Callable[[float, McuObservation], None]) -> None:
        """What the device does at the current tick without stepping the physics: commands that have arrived,
        acting ticks, the PWM frame, a due reading. Safe to call again at the same tick (nothing repeats);
        a real-time rig calls it after `run` so a reading due now leaves now, not a tick later."""
        tick, tick_ms = self.tick, self._tick_ms
        now_ms = tick * tick_ms
        scheduler, pending, mcu = self.scheduler, self._pending, self.mcu
        acting, onboard = scheduler.acting, mcu.onboard
        at_pwm = (tick - self._pwm_phase_ticks) % self._pwm_ticks == 0
        if (at_pwm or (pending and pending[0][0] <= now_ms) or (onboard.running and acting.next_ms <= now_ms)
                or (scheduler.streaming_on and scheduler.streaming.next_ms <= now_ms) or scheduler.observe_once):
            self._take_commands_and_acting_ticks(now_ms)
        if at_pwm:
            self._act[0] = self.params.servo_counts_to_rad(mcu.servo_counts)
        # streaming_due has effects only when it says yes: asked only when it may
        if ((scheduler.streaming_on and scheduler.streaming.next_ms <= now_ms) or scheduler.observe_once) \
                and scheduler.streaming_due(now_ms):
            if self.encoder_fault is None:  # the common case, without a call
                emit(now_ms, mcu.streaming_tick(self.raw_encoder_counts(), int(now_ms)))
            else:
                emit(now_ms, self._read_and_stream())

    def _take_commands_and_acting_ticks(self, now_ms: float) -> None:
        """Acting ticks and command arrivals up to `now_ms`, in time order (a command before a tick at the same
        moment). Commands act on arrival, as in the firmware's message callback."""
        scheduler, pending, mcu, tick_ms = self.scheduler, self._pending, self.mcu, self._tick_ms
        acting, onboard = scheduler.acting, mcu.onboard
        while True:
            acting_ms = acting.next_ms
            if pending and pending[0][0] <= now_ms and pending[0][0] <= acting_ms:
                arrival_ms, command, _ = pending.popleft()
                scheduler.receive(command, int(math.ceil(arrival_ms / tick_ms) * tick_ms))
            elif acting_ms <= now_ms:
                acting.next_ms = acting_ms + acting.period_ms  # Schedule.due at its own deadline: never a skip
                mcu.acting_tick(int(acting_ms), self._onboard_reading() if onboard.running else None)
            else:
                break

    def raw_encoder_counts(self) -> int:
        counts = self.params.encoder_counts
        angle = self._qpos.item(self._pendulum_qpos)
        return (math.floor(angle * counts / (2 * math.pi)) + self.mount_offset_counts) % counts

    def _onboard_reading(self) -> int:
        """The encoder as the controller reads it on an acting tick (a stuck encoder repeats itself)."""
        if self.encoder_fault == "stuck" and self._stuck_raw is not None:
            return self._stuck_raw
        return self.raw_encoder_counts()

    def _read_and_stream(self) -> McuObservation:
        raw, now_ms = self.raw_encoder_counts(), int(self.tick * self._tick_ms)
        if self.encoder_fault is None:
            return self.mcu.streaming_tick(raw, now_ms)
        if self.encoder_fault == "stuck":  # a seized shaft or a frozen chip: the same valid frame forever
            self._stuck_raw = raw if self._stuck_raw is None else self._stuck_raw
            return self.mcu.streaming_frame(encode_ssi_frame(self._stuck_raw), now_ms)
        return self.mcu.streaming_frame(encode_ssi_frame(raw, corrupt_parity=True), now_ms)  # "garbage"
