"""The loop around the device's logic: which commands it takes, when it acts and streams, what it sends.

`DeviceScheduler.receive(payload, now_ms)` is the one command path: the text as it arrives is parsed,
scheduling commands (periods, streaming on/off, one observation, status) are kept here, everything else
goes to `McuLogic.apply`. `observation_line` formats what a streaming tick produced: v2 (`R...`, with the
sequence number and the last command's echo) once the host has spoken v2, else v1 (`S...`).

`protocol=1` is the authors' firmware: single-letter commands only (a v2 frame or a heartbeat is not a
command it knows, so it is ignored and counted), no watchdog, and silent until told to stream (`x`).
"""

from __future__ import annotations

from pendkit.backend_contract import FLAG_BITS
from pendkit.device.commands import DeviceCommand, parse_command
from pendkit.device.logic import McuLogic
from pendkit.device.observation import McuObservation
from pendkit.device.onboard import is_chunk
from pendkit.device.protocol import ProtocolError, format_observation_v1, format_observation_v2
from pendkit.errors import ConfigError
from pendkit.rig import RigParams

PROTOCOLS = (1, 2)
# commands that set a flag: kind -> (attribute, value)
FLAG_COMMANDS = {"stream_on": ("streaming_on", True), "stream_off": ("streaming_on", False),
                 "observe_once": ("observe_once", True), "status": ("status_requested", True)}
SCHEDULING = ("stream_on", "stream_off", "observe_once", "streaming_period", "acting_period", "status")
V1_KINDS = ("action", "target", "encoder_offset", "filter", "stream_on", "stream_off", "observe_once",
            "streaming_period", "acting_period", "continuous_mode", "discrete_mode")


class Schedule:
    """Fixed-rate deadlines for a tick; a late loop catches up by skipping, never by bursting."""

    def __init__(self, period_ms: float, start_ms: float = 0) -> None:
        self.period_ms, self.next_ms = period_ms, start_ms

    def due(self, now_ms: float) -> bool:
        if now_ms < self.next_ms:
            return False
        self.next_ms += self.period_ms
        if now_ms >= self.next_ms:  # missed ticks: skip them
            self.next_ms = now_ms + self.period_ms
        return True


class DeviceScheduler:
    """One device's command path, periods and outgoing bookkeeping; the logic is `self.logic`."""

    def __init__(self, params: RigParams, protocol: int = 2) -> None:
        if protocol not in PROTOCOLS:
            raise ConfigError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
        self.params, self.protocol = params, protocol
        self.logic = McuLogic(params)
        if protocol == 1:
            self.logic.watchdog_timeout_ms = float("inf")  # the authors' firmware has none
        self.acting = Schedule(params.acting_period_ms)
        self.streaming = Schedule(params.streaming_period_ms)
        self.streaming_on = protocol == 2  # ours streams from power-up; the authors' waits for `x`
        self.observe_once = False
        self.status_requested = False
        self.host_speaks_v2 = False
        self.observation_seq = self.command_seq = self.echo_host_ms = 0
        self.rejected_commands = 0

    @property
    def acting_period_ms(self) -> float:
        return self.acting.period_ms

    @property
    def streaming_period_ms(self) -> float:
        return self.streaming.period_ms

    def acting_due(self, now_ms: float) -> bool:
        """Whether the acting tick is due now (then `logic.acting_tick(now_ms)`)."""
        return self.acting.due(now_ms)

    def streaming_due(self, now_ms: float) -> bool:
        """Whether an observation is due now: the streaming period while streaming, or one asked for."""
        if (self.streaming_on and self.streaming.due(now_ms)) or self.observe_once:
            self.observe_once = False
            return True
        return False

    def take_status_request(self) -> bool:
        requested, self.status_requested = self.status_requested, False
        return requested

    def reset(self, servo_counts: int, now_ms: int = 0) -> None:
        """Power-up state of the logic; the link's bookkeeping (sequence numbers, protocol) carries on."""
        self.logic.reset(servo_counts, now_ms)
        self.acting.next_ms = self.streaming.next_ms = now_ms
        self.observe_once = False

    def receive(self, payload: str | bytes | DeviceCommand, now_ms: int) -> DeviceCommand | None:
        """Take one command (or upload chunk) as it arrived; a malformed or unknown one is counted and
        changes nothing."""
        if type(payload) is not str and is_chunk(payload):  # commands are text; chunks bytes
            if self.protocol == 1:  # the authors' firmware has no controller topic
                self.rejected_commands += 1
            else:
                onboard = self.logic.onboard
                settled = onboard.blobs_accepted + onboard.blobs_refused
                onboard.chunk(payload)
                if onboard.blobs_accepted + onboard.blobs_refused != settled:
                    self.status_requested = True  # an upload ended: say how
            return None
        try:
            command = payload if isinstance(payload, DeviceCommand) else parse_command(payload)
        except ProtocolError:
            self.rejected_commands += 1
            return None
        if self.protocol == 1 and (command.seq is not None or command.host_ms is not None
                                   or command.kind not in V1_KINDS):
            self.rejected_commands += 1
            return None
        if command.seq is not None:
            self.host_speaks_v2, self.command_seq = True, command.seq
        if command.host_ms is not None:
            self.echo_host_ms = command.host_ms
        self.apply(command, now_ms)
        return command

    def apply(self, command: DeviceCommand, now_ms: int) -> None:
        kind, value = command.kind, command.value
        if kind in FLAG_COMMANDS:
            setattr(self, *FLAG_COMMANDS[kind])
        elif kind == "streaming_period":
            self.streaming.period_ms = value
        elif kind == "acting_period":
            self.acting.period_ms = value
        else:
            self.logic.apply(command, now_ms)

    def observation_line(self, observation: McuObservation) -> str:
        """The text a streaming tick publishes; every observation takes the next sequence number."""
        if self.host_speaks_v2:
            line = format_observation_v2(observation, self.observation_seq, self.command_seq, self.echo_host_ms)
        else:
            line = format_observation_v1(observation)
        self.observation_seq += 1
        return line

    def status(self) -> dict:
        """The retained status: what the device runs with, so a host can report a mismatch."""
        logic, p = self.logic, self.params
        return {"protocol": self.protocol,
                "streaming_ms": round(self.streaming_period_ms), "acting_ms": round(self.acting_period_ms),
                "mode": logic.command.mode, "online": True,
                "flags": sum(bit for name, bit in FLAG_BITS.items() if name in logic.flags) & 15,
                "rejected_commands": self.rejected_commands,
                "servo_counts_range": [p.servo_min_counts, p.servo_max_counts],
                **({"controller": logic.onboard.status()} if self.protocol == 2 else {})}
