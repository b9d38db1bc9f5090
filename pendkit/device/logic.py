"""The firmware's control loop in Python, with time passed in; the C++ core (firmware/lib/pendcore)
follows the same rules, and tests/vectors/device.json holds both to them.

Two independent ticks, as on the device: the acting tick moves the servo target; the streaming tick
reads the encoder, estimates velocities and produces an observation. Safety stops are applied last,
right before actuation, and no command can override them:
- watchdog: no command or heartbeat for `watchdog_timeout_ms` -> hold the servo;
- over-spin: |omega| above the limit -> hold the servo (the limit can be set to 0 = off);
- stuck encoder: 8 bad frames in a row, or no change while the arm travelled 60 counts -> hold;
- arm limits: the target is clipped to the servo's counts, and a discrete action ends there.
An uploaded controller (`pendkit.device.onboard`), once started with `k1`, chooses the target on every
acting tick from the encoder read on that tick; the same stops apply to it.
"""

from __future__ import annotations

import math

from pendkit.backend_contract import STOP, ServoCommand
from pendkit.device.observation import McuObservation, observation_to_state  # noqa: F401 - also named here
from pendkit.device.onboard import OnboardController
from pendkit.encoder import FirmwareVelocityEstimator, frame_status
from pendkit.rig import RigParams

HOLDING_FLAGS = frozenset(("watchdog", "overspin", "stuck_encoder"))
STUCK_BAD_FRAMES = 8
STUCK_TRAVEL_COUNTS = 60
FRAME_ERROR = frozenset(("frame_error",))
# settings a command sets as decoded: its kind -> the attribute
SETTING_ATTRIBUTES = {"filter": "device_filter", "watchdog_timeout": "watchdog_timeout_ms",
                      "overspin_limit": "overspin_limit_rev_s"}
NO_FLAGS: frozenset[str] = frozenset()


def action_increments_counts(params: RigParams) -> tuple[int, ...]:
    """The one table from a discrete action index to the servo target's change per acting tick (counts)."""
    slow, fast = params.discrete_slow_step_counts, params.discrete_fast_step_counts
    return (0, -slow, -fast, slow, fast)


def discrete_command(index: int, params: RigParams) -> ServoCommand:
    return ServoCommand("discrete", action_increments_counts(params)[index], action=index)


def round_half_up(value: float) -> int:
    """floor(x + 0.5): the rounding the C++ core uses (Python's round() rounds halves to even)."""
    return math.floor(value + 0.5)


class McuLogic:
    """Servo command, velocity estimation, settings and safety of one device."""

    def __init__(self, params: RigParams) -> None:
        self.params = params
        self.estimator = FirmwareVelocityEstimator(params.velocity_mean_window, params.encoder_counts)
        self.offset_counts = params.encoder_offset_counts
        self.watchdog_timeout_ms = params.watchdog_timeout_ms
        self.overspin_limit_rev_s = params.overspin_limit_rev_s
        self.device_filter = 0.0  # the kit filters on the host; `e<c>` restores the authors' device filter
        self.onboard = OnboardController(params)  # kept across resets, as in the firmware's RAM
        self._discrete_commands = tuple(discrete_command(k, params)
                                        for k in range(len(action_increments_counts(params))))
        self.last_observation: McuObservation | None = None
        self.reset(round_half_up(params.servo_centre_counts), 0)

    def reset(self, servo_counts: int, now_ms: int) -> None:
        self.servo_counts = servo_counts
        self.command: ServoCommand = STOP
        self.last_command_ms = now_ms
        self.estimator.reset()
        self.omega_rev_s = 0.0
        self._filtered_unit = (servo_counts - self.params.servo_centre_counts) * 2 / self.params.servo_span_counts
        self._last_stream_servo = servo_counts
        self._last_stream_ms = now_ms
        self._last_raw: int | None = None
        self._bad_frames = 0
        self._servo_at_last_change = servo_counts
        self.flags: set[str] = set()
        self.onboard.stop()
        self._onboard_was_running = False
        self.last_observation = None

    # --- commands ---
    def receive(self, command: ServoCommand, now_ms: int) -> None:
        self.command = command
        self.heartbeat(now_ms)

    def heartbeat(self, now_ms: int) -> None:
        self.last_command_ms = now_ms
        self.flags.discard("watchdog")

    def apply(self, command, now_ms: int) -> None:
        """The one entry for a decoded `pendkit.device.commands.DeviceCommand` (actions, settings, heartbeat)."""
        kind, value = command.kind, command.value
        if kind in ("action", "target"):
            self.onboard.stop()  # the host takes over: its command is in force, not a hold
            self._onboard_was_running = False
        if kind == "action":
            self.receive(self._discrete_commands[int(value)], now_ms)
        elif kind == "target":
            self.receive(ServoCommand("continuous", target_unit=value), now_ms)
        elif kind == "onboard":
            self.heartbeat(now_ms)
            if value:
                target_rad = self.params.servo_counts_to_rad(self.servo_counts)
                self.onboard.start(self.pendulum_rad(self._last_raw), target_rad)
            else:
                self.onboard.stop()
        elif kind == "heartbeat":
            self.heartbeat(now_ms)
        elif kind == "encoder_offset":
            self.offset_counts = int(value)
        elif kind in SETTING_ATTRIBUTES:
            setattr(self, SETTING_ATTRIBUTES[kind], value)
        elif kind == "velocity_window":  # a shorter mean lags less and is noisier (lab 02)
            self.estimator = FirmwareVelocityEstimator(int(value), self.params.encoder_counts)
        # periods, streaming on/off, modes, status requests belong to the scheduler and the link

    # --- acting tick ---
    def pendulum_rad(self, raw_counts: int | None) -> float:
        """A raw encoder reading as the calibrated angle from the bottom (0 before any reading)."""
        if raw_counts is None:
            return 0.0
        counts = self.params.encoder_counts
        return ((raw_counts - self.offset_counts) % counts) * (2 * math.pi / counts)

    def acting_tick(self, now_ms: int, raw_counts: int | None = None) -> int:
        """Advance the servo target by the current command, or by the running onboard controller from the
        encoder read now (`raw_counts`); return the counts to actuate."""
        p, flags, running = self.params, self.flags, self.onboard.running
        if now_ms - self.last_command_ms > self.watchdog_timeout_ms:
            flags.add("watchdog")
        if self._onboard_was_running and not running:
            # stopped by k0, a new blob or anything else: hold here until the host commands, never resume
            # the host's command from before k1 (a stale target, or a policy's last ramp to the arm's limit)
            self.command = STOP
        self._onboard_was_running = running
        if running:
            wanted = self._onboard_wanted(now_ms, raw_counts)
        elif self.command.mode == "continuous":  # the host's command (the common case, taken first)
            c = self.device_filter
            self._filtered_unit = c * self._filtered_unit + (1 - c) * self.command.target_unit
            wanted = round_half_up(p.servo_centre_counts + self._filtered_unit * p.servo_span_counts / 2)
        else:
            wanted = self.servo_counts + self.command.increment_counts
        if flags and not flags.isdisjoint(HOLDING_FLAGS):  # safety last: hold the servo where it is
            wanted = self.servo_counts
        low, high = p.servo_min_counts, p.servo_max_counts
        clipped = low if wanted < low else high if wanted > high else wanted
        if clipped != wanted or clipped == low or clipped == high:
            flags.add("arm_limit")
            if self.command.mode == "discrete" and clipped != wanted:
                self.command = STOP  # a discrete action ends at the arm's limit
        elif flags:
            flags.discard("arm_limit")
        self.servo_counts = clipped
        return clipped

    def _onboard_wanted(self, now_ms: int, raw_counts: int | None) -> int:
        """The target an acting tick wants while the uploaded controller runs (before the stops)."""
        p, onboard = self.params, self.onboard
        policy_runs = onboard.runs_a_policy
        if policy_runs:
            action = onboard.policy_tick(self.last_observation, now_ms)
            if action is None:
                pass
            elif onboard.runtime.continuous:  # a target, already through its own filter
                self.command = ServoCommand("continuous", target_unit=action)
            else:  # as a host's action command would, without feeding the watchdog
                self.command = discrete_command(action, p)
        if onboard.running and raw_counts is not None and not onboard.runs_a_policy:
            target_rad = onboard.tick(self.pendulum_rad(raw_counts), p.servo_counts_to_rad(self.servo_counts))
            counts = p.servo_centre_counts + target_rad / p.servo_rad_per_count
            return round_half_up(counts) if math.isfinite(counts) else self.servo_counts  # diverged: hold
        if self.command.mode == "continuous":
            c = 0.0 if policy_runs else self.device_filter
            self._filtered_unit = c * self._filtered_unit + (1 - c) * self.command.target_unit
            return round_half_up(p.servo_centre_counts + self._filtered_unit * p.servo_span_counts / 2)
        return self.servo_counts + self.command.increment_counts

    # --- streaming tick ---
    def streaming_frame(self, frame: int, now_ms: int) -> McuObservation:
        """Decode an SSI frame and stream; a bad frame repeats the last good reading and is flagged."""
        if frame_status(frame) != "ok":
            self._bad_frames += 1
            if self._bad_frames >= STUCK_BAD_FRAMES:
                self.flags.add("stuck_encoder")
            raw = self._last_raw if self._last_raw is not None else self.offset_counts
            return self._stream(raw, now_ms, frame_error=True)
        self._bad_frames = 0
        return self._stream(frame >> 6, now_ms, frame_error=False)

    def streaming_tick(self, raw_counts: int, now_ms: int) -> McuObservation:
        """Stream from a raw (uncalibrated) encoder position."""
        self._bad_frames = 0
        return self._stream(raw_counts, now_ms, frame_error=False)

    def _stream(self, raw_counts: int, now_ms: int, frame_error: bool) -> McuObservation:
        flags, servo_counts = self.flags, self.servo_counts
        if not frame_error:
            if raw_counts != self._last_raw:
                self._servo_at_last_change = servo_counts
                if self._bad_frames == 0:
                    flags.discard("stuck_encoder")
            elif abs(servo_counts - self._servo_at_last_change) >= STUCK_TRAVEL_COUNTS:
                flags.add("stuck_encoder")
            self._last_raw = raw_counts
        position = (raw_counts - self.offset_counts) % self.params.encoder_counts
        omega, accel = self.estimator.update(position, now_ms)
        self.omega_rev_s = omega
        if self.overspin_limit_rev_s > 0 and abs(omega) > self.overspin_limit_rev_s:
            flags.add("overspin")
        else:
            flags.discard("overspin")
        dt_ms = now_ms - self._last_stream_ms
        arm_velocity = ((servo_counts - self._last_stream_servo) * 1000.0 / dt_ms) if dt_ms > 0 else 0.0
        self._last_stream_servo, self._last_stream_ms = servo_counts, now_ms
        shown = frozenset(flags | FRAME_ERROR) if frame_error else frozenset(flags) if flags else NO_FLAGS
        self.last_observation = McuObservation(now_ms, position, servo_counts, omega, accel, arm_velocity, shown)
        return self.last_observation


def calibrate_position(raw_counts: int, offset_counts: int, counts: int = 1024) -> int:
    """Raw encoder reading -> position with 0 at the bottom (the firmware's `o<int>` offset)."""
    return (raw_counts - offset_counts) % counts
