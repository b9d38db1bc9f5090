"""`RigBackend`: the real rig (or a virtual one) behind the same env, over MQTT.

A step publishes the command without waiting for anything, sleeps to the step's absolute deadline
(deadlines never drift: each is the previous plus the period), and reads the newest observation. It never
blocks on the network; if no observation has arrived for `observation_timeout_s` it raises
`RigLinkError` saying what to check. Reset follows the paper: stop the servo and wait 2 s (the pendulum
keeps whatever motion it has), or until it has settled when asked.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from pendkit.backend_contract import STOP, RigState, ServoCommand
from pendkit.device.commands import command_body, frame_command
from pendkit.device.observation import observation_to_state
from pendkit.device.scheduler import PROTOCOLS
from pendkit.errors import ConfigError
from pendkit.link.driver import DEFAULT_BROKER, RigLink, RigLinkError
from pendkit.network import CLASSROOM_WIFI, median_latency_ms
from pendkit.rig import SERVO_PRESETS, RigParams
from pendkit.telemetry.log import EpisodeLog
from pendkit.telemetry.parse import ReadingLimits
from pendkit.timing import host_timing

SETTLED_REV_S = 0.05
SETTLE_HOLD_S = 1.0
SETTLE_LIMIT_S = 60.0
HEARTBEAT_S = 0.05
ASSUMED_LATENCY_MS = median_latency_ms(CLASSROOM_WIFI)  # until you measure your room's (lab 06)


def is_servo_counts_range(value) -> bool:
    """A status's `servo_counts_range` as a device writes it: [min, max] whole counts, min below max."""
    return (isinstance(value, list) and len(value) == 2
            and all(isinstance(n, int) and not isinstance(n, bool) for n in value)
            and 0 <= value[0] < value[1] <= 65535)


def servo_mismatch(device_range: list[int], params: RigParams, rig: str,
                   what: str = "the host's parameters are set") -> str | None:
    """Why `params` (what a controller or policy was designed for) must not drive a rig whose firmware reports
    `device_range`, naming both servos and what to use instead; None when they agree."""
    designed = [params.servo_min_counts, params.servo_max_counts]
    if list(device_range) == designed:
        return None
    fitting = [name for name in SERVO_PRESETS if [RigParams.preset(name).servo_min_counts,
                                                   RigParams.preset(name).servo_max_counts] == list(device_range)]
    its_servo = f" (the range of the {', '.join(fitting)} preset{'s' if len(fitting) > 1 else ''})" if fitting else ""
    use = f"--preset {fitting[0]}, or " if fitting else ""
    return (f"{rig}'s firmware drives servo counts {device_range[0]}..{device_range[-1]}{its_servo}, but {what} "
            f"for {designed[0]}..{designed[1]} ({params.servo_name}): use the "
            f"rig's own servo: {use}--params RIG.json (`pendkit adapt` writes one; in Python "
            "params=RigParams.load(...))")


class RigBackend:
    """The env's backend for a rig on a broker. `rig` names it (r01); `broker` is a URL."""

    def __init__(self, params: RigParams | None = None, rig: str = "r01", broker: str | None = None,
                 username: str | None = None, password: str | None = None, tls_ca: str | None = None,
                 observation_timeout_s: float = 0.5, reset_stop_s: float = 2.0, settle: bool = False,
                 log_dir: str | Path | None = None, connect_timeout_s: float = 5.0, protocol: int = 2,
                 network_latency_ms: float = ASSUMED_LATENCY_MS) -> None:
        """`network_latency_ms`: the one-way latency controllers should expect (measure yours in lab 06).
        `protocol=1`: a rig flashed with the authors' firmware (single letters, no framing, no heartbeats,
        no watchdog on the device: the host is all the safety there is; see docs/protocol.md)."""
        if protocol not in PROTOCOLS:
            raise ConfigError(f"protocol must be 1 (the authors' firmware) or 2 (the kit's), got {protocol!r}")
        self.protocol = protocol
        if protocol == 1 and params is not None and params.velocity_mean_window != 4:
            raise ConfigError(f"the authors' v1 firmware always averages 4 rates; params ask for "
                              f"{params.velocity_mean_window} (use protocol 2, or RigParams' default window)")
        if not 0.05 <= observation_timeout_s <= 30:
            raise ConfigError(f"observation_timeout_s must be in [0.05, 30], got {observation_timeout_s}")
        self.params = params or RigParams()
        self.rig, self.observation_timeout_s = rig, observation_timeout_s
        self.reset_stop_s, self.settle = reset_stop_s, settle
        self.log_dir = Path(log_dir) if log_dir is not None else None
        if not 0 <= network_latency_ms <= 1000:
            raise ConfigError(f"network_latency_ms must be in [0, 1000], got {network_latency_ms!r}")
        self.nominal_step_s = self.params.control_step_ms / 1000.0
        self.timing = host_timing(self.params, self.nominal_step_s, network_latency_ms, network_latency_ms)
        self.link = RigLink(rig, broker or DEFAULT_BROKER, username, password, tls_ca,
                            limits=ReadingLimits.for_rig(self.params))
        self.link.connect(connect_timeout_s)
        self._seq = 0
        self._deadline = time.monotonic()
        self._sent_at = time.monotonic()
        self._episodes = 0
        self.step_period_errors_s: list[float] = []
        self.publish_failures = 0
        self.estopped = False
        self.last_step_at: float | None = None

    # --- commands ---
    def _send(self, text: str) -> None:
        """Publish without waiting; a failure is counted, and the observation timeout reports the outage."""
        if self.protocol == 1 and text == "h":
            return  # v1 has no heartbeat: commands themselves keep a v1 device going
        self._seq += 1
        if not self.link.publish(frame_command(text, self.protocol, self._seq, int(time.monotonic() * 1000))):
            self.publish_failures += 1

    def _configure(self) -> None:
        """What a fresh device needs: calibration, the host-side filter, the stream's period and velocity
        window (RigParams' values; the defaults are the paper's), streaming on."""
        p = self.params
        window = [f"n{p.velocity_mean_window}"] if self.protocol == 2 else []  # v1 firmware: always 4
        for text in (f"o{p.encoder_offset_counts}", "e0", f"u{round(p.streaming_period_ms)}", *window, "x"):
            self._send(text)

    # --- the env's backend interface ---
    def reset(self, rng: np.random.Generator, start: str = "random", initial: dict | None = None) -> RigState:
        if initial:
            raise ConfigError("a real rig cannot be put into a chosen state: reset(options=...) may only set "
                              "'start', and the rig starts from wherever the pendulum is")
        if self.log_dir is not None:
            previous = self.link.log
            self._episodes += 1
            self.link.log = EpisodeLog(self.log_dir / f"episode-{self._episodes:04d}.jsonl")
            if previous is not None:
                previous.close()
        # a device built for another servo is refused as soon as its status says so: before any command
        # reaches it, and without waiting on the readings (a busy laptop's late ones must not hide the cause)
        self._check_device_config()
        self._configure()
        self._send(command_body(STOP, self.params))
        began = time.monotonic()
        quiet_since = None
        while True:
            time.sleep(HEARTBEAT_S)
            self._check_device_config()
            self._send("h")
            now = time.monotonic()
            waited = now - began
            if waited < self.observation_timeout_s and not self._fresh(now):
                continue  # a device just told to stream (or a slow network) gets its stated time
            self._require_fresh(now)
            omega = abs(self.link.newest.received.observation.omega_rev_s)
            quiet_since = (quiet_since or now) if omega < SETTLED_REV_S else None
            settled = quiet_since is not None and now - quiet_since >= SETTLE_HOLD_S
            if waited >= self.reset_stop_s and (settled or not self.settle):
                break
            if waited > SETTLE_LIMIT_S:
                raise RigLinkError(f"rig {self.rig}: the pendulum did not settle within {SETTLE_LIMIT_S:g} s")
        self._check_device_config()
        self._deadline = self._sent_at = time.monotonic()
        self.last_step_at = None
        return self._state(time.monotonic())

    def _check_device_config(self) -> None:
        """A v2 device's retained status says which servo range it was built for: refuse to drive a rig whose
        firmware and host disagree (the arm angles and the limits would both be wrong)."""
        try:
            status = json.loads(self.link.status) if self.link.status else {}
        except json.JSONDecodeError:
            return
        device_range = status.get("servo_counts_range") if isinstance(status, dict) else None
        if device_range is None:
            return
        if not is_servo_counts_range(device_range):
            raise RigLinkError(f"rig {self.rig}'s status says servo_counts_range {str(device_range)[:40]}, not "
                               "[min, max] counts: a malformed or forged status (anyone may publish on an open "
                               "broker: use the classroom broker's ACLs, docs/protocol.md); restart the rig")
        mismatch = servo_mismatch(device_range, self.params, f"rig {self.rig}")
        if mismatch is not None:
            raise ConfigError(mismatch)

    def emergency_stop(self) -> None:
        """Stop the servo now and keep it stopped: every later step sends stop instead of its action."""
        self.estopped = True
        self._send(command_body(STOP, self.params))

    def release_stop(self) -> None:
        self.estopped = False

    def step(self, command: ServoCommand) -> RigState:
        self._send(command_body(STOP if self.estopped else command, self.params))
        self._sent_at = time.monotonic()
        self._deadline += self.nominal_step_s
        pause = self._deadline - time.monotonic()
        if pause > 0:
            time.sleep(pause)
        elif pause < -self.nominal_step_s:
            self._deadline = time.monotonic()  # far behind (a stalled learner): start afresh, never burst
        now = time.monotonic()
        if self.last_step_at is not None:
            self.step_period_errors_s.append(now - self.last_step_at - self.nominal_step_s)
        self.last_step_at = now
        self._require_fresh(now)
        return self._state(now)

    def close(self) -> None:
        try:
            if self.link.connected:
                self._send(command_body(STOP, self.params))
        finally:
            self.link.close()
            if self.link.log is not None:
                self.link.log.close()

    @property
    def episode_log(self) -> EpisodeLog | None:
        """This episode's message log (None without `log_dir`)."""
        return self.link.log if self.log_dir is not None else None

    def observation_age_now(self) -> float:
        """Seconds since the newest observation arrived (inf if none has)."""
        newest = self.link.newest
        return float("inf") if newest is None else time.monotonic() - newest.receive_time_s

    # --- observations ---
    def _fresh(self, now: float) -> bool:
        newest = self.link.newest
        return newest is not None and now - newest.receive_time_s <= self.observation_timeout_s

    def _require_fresh(self, now: float) -> None:
        newest = self.link.newest
        if not self._fresh(now):
            age = "none yet" if newest is None else f"the last {now - newest.receive_time_s:.2f} s ago"
            state = "connected" if self.link.connected else "NOT connected (reconnecting)"
            if newest is None and self.link.connected:  # never heard from: name the likely cause
                raise RigLinkError(f"no observation from rig {self.rig} within {self.observation_timeout_s:g} s "
                                   f"(none yet): {self.link.why_silent()}")
            raise RigLinkError(f"no observation from rig {self.rig} within {self.observation_timeout_s:g} s ({age}); "
                               f"the link to {self.link.address} is {state}. Check that the rig is powered and "
                               "online, and the broker running; the env works again once observations flow.")

    def _state(self, now: float) -> RigState:
        arrival = self.link.newest
        return observation_to_state(arrival.received.observation, self.params, now - arrival.receive_time_s,
                                    now - self._sent_at)
