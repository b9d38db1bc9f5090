"""The unattended reset between episodes, and what makes a rig unfit to go on.

A reset stops the uploaded controller (`k0`), then brakes the swing from the host: the arm's target moves
against the pumping direction of the energy law (`pendkit.control.swingup`, the same quarter-period phase
rule) at a rate proportional to the swing's amplitude, while it is pulled back to the centre; once the
pendulum hangs still (the encoder within 3 counts for 1 s of the rig's time, across the 1023/0 wrap) with the
arm within a count or two of the centre, the arm goes to the centre exactly and holds until the pendulum hangs
still again. Dropped from upright, the twin's pendulum hangs still after about 15 s with the arm held at the
centre, braked after 7-9 s (virtual rig at 10x; at 20x on a loaded machine the host's loop is late and the brake
gains less). Readings too old to brake on move nothing, and a swing that gains energy (late
readings turn the phase) is left to the arm held at the centre. The rig's own stops stay in charge: the targets
are ordinary commands, clipped and held by the device like any other.

A rig that does not settle within `RESET_LIMIT_S`, goes silent or offline, or reports a stuck encoder is
unfit (`RigFault`): the runner takes it out of service with the reason and the job runs on another rig.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable

from pendkit.control.swingup import pumping_acceleration_sign
from pendkit.errors import PendkitError
from pendkit.features import pendulum_energy
from pendkit.queue.jobs import RESET_LIMIT_S
from pendkit.rig import RigParams

STILL_COUNTS = 3  # the encoder's spread over STILL_S that counts as hanging still (a count's flicker allowed)
STILL_S = 1.0
CENTRED_RAD = 0.02  # the arm's target this close to the centre is the centre
BRAKE_RATE_RAD_S = 3.0  # the target's fastest move while braking (under every preset's rated speed)
BRAKE_GAIN_PER_RAD = 1.0  # full rate at a swing of 1 rad, proportionally less below
CENTRING_PER_S = 1.0
BRAKE_ARM_LIMIT_RAD = 1.0  # inside every preset's range: braking never drives the arm to its end stop
EARLIER_SWING_RAD = 1.2  # as pendkit.control.swingup: the phase is asked of a swing at most this big
# the brake is a feedback law and needs the swing's present: a reading older than this many control steps (of the
# rig's time) moves nothing; a swing whose amplitude (the largest angle from hanging over the last SWING_S, longer
# than a period) grew this much above the least it had is being pumped (readings late on a loaded machine turn the
# phase): the arm then goes to the centre and holds, braking no more
STALE_STEPS = 2
SWING_S = 1.5
PUMPED_RAD = 0.2
SILENT_S = 2.0  # rig seconds without a reading: the rig is silent
# ... and at least this long on this machine's clock: a busy machine is not a dead rig (virtual rigs in processes of
# their own on two saturated cores went a second without a reading)
SILENT_WALL_MIN_S = 3.0
# rig seconds the stuck-encoder stop may stay set: it is also set for a moment when the target jumps 60 counts
# within one reading (a plan's first step), and cleared by the encoder's next change
STUCK_HOLD_S = 1.0


class RigFault(PendkitError):
    """The rig cannot go on (silent, offline, unsettled, a stuck encoder): out of service, its job runs again."""


class JobStopped(PendkitError):
    """The job ends early with this reason (its time limit, the rig's safety stopping its controller)."""


class JobCancelled(PendkitError):
    """The team (or the instructor) cancelled the job."""


class RunnerStopping(PendkitError):
    """The runner is shutting down: the job goes back to waiting."""


class RigWatch:
    """What a rig's link says of its health; `problem()` is None while it is fit."""

    def __init__(self, link, speed: float) -> None:
        self.link, self.speed = link, speed
        self._status_text: str | None = None
        self._offline = False
        self._stuck_since_ms: int | None = None

    def offline(self) -> bool:
        text = self.link.status
        if text != self._status_text:
            self._status_text = text
            try:
                status = json.loads(text) if text else {}
            except ValueError:
                status = {}
            self._offline = isinstance(status, dict) and status.get("online") is False
        return self._offline

    def problem(self) -> str | None:
        if self.offline():
            return f"rig {self.link.rig} went offline (its status says so: powered off, or its WiFi dropped)"
        newest = self.link.newest
        quiet_s = time.monotonic() - newest.receive_time_s if newest is not None else math.inf
        if quiet_s > max(SILENT_S / self.speed, SILENT_WALL_MIN_S):
            shown = "never sent a reading" if newest is None else f"sent no reading for {quiet_s * self.speed:.1f} s"
            return f"rig {self.link.rig} {shown} (powered off, its WiFi, or the broker)"
        observation = newest.received.observation
        if "stuck_encoder" not in observation.flags:
            self._stuck_since_ms = None
            return None
        if self._stuck_since_ms is None or observation.millis < self._stuck_since_ms:
            self._stuck_since_ms = observation.millis
        if observation.millis - self._stuck_since_ms >= STUCK_HOLD_S * 1000:
            return (f"rig {self.link.rig}'s encoder is stuck (the device's stuck-encoder stop held the servo for "
                    f"{STUCK_HOLD_S:g} s): check the encoder and its cable")
        return None

    def check(self) -> None:
        problem = self.problem()
        if problem is not None:
            raise RigFault(problem)


def spread_counts(positions: list[int], counts: int = 1024) -> int:
    """The encoder's spread over `positions`, taken across the wrap (1023 and 0 are one count apart)."""
    half = counts // 2
    offsets = [(p - positions[0] + half) % counts - half for p in positions]
    return max(offsets) - min(offsets)


class Swing:
    """The swing's amplitude: the largest angle from hanging over the last `steps` readings (None until then)."""

    def __init__(self, steps: int) -> None:
        self.steps, self.angles_rad = steps, []

    def update(self, angle_from_bottom_rad: float) -> float | None:
        wrapped = abs((angle_from_bottom_rad + math.pi) % (2 * math.pi) - math.pi)
        self.angles_rad = (self.angles_rad + [wrapped])[-self.steps:]
        return max(self.angles_rad) if len(self.angles_rad) == self.steps else None


def brake_rate_rad_s(angle_from_bottom_rad: float, velocity_rad_s: float, target_rad: float,
                     natural_frequency_rad_s: float) -> float:
    """The arm target's rate that takes energy out of the swing (the energy law's pumping direction reversed,
    `SwingUpController.swing_rate_rad_s` without a lead), plus the pull back to the centre."""
    w0 = natural_frequency_rad_s
    energy = pendulum_energy(angle_from_bottom_rad, velocity_rad_s, w0)
    amplitude_rad = math.sqrt(max(0.0, 2.0 * (energy + 1.0)))  # a small swing's amplitude from its energy
    angle = (angle_from_bottom_rad + math.pi) % (2 * math.pi) - math.pi
    rate = velocity_rad_s / w0
    earlier_angle, earlier_rate = -rate, angle  # a quarter period back: the servo follows the target's integral
    scale = min(1.0, EARLIER_SWING_RAD / max(math.hypot(earlier_angle, earlier_rate), 1e-12))
    pumping = pumping_acceleration_sign(earlier_angle * scale, earlier_rate * scale * w0)
    return -pumping * BRAKE_RATE_RAD_S * min(1.0, BRAKE_GAIN_PER_RAD * amplitude_rad) - CENTRING_PER_S * target_rad


def reset_rig(session, params: RigParams, speed: float, check: Callable[[], None] = lambda: None,
              limit_s: float = RESET_LIMIT_S) -> float:
    """Stop the controller, brake the swing, centre the arm and hold it until the pendulum hangs still; the rig
    seconds it took. `RigFault` when the rig is unfit or does not settle within `limit_s`; `check()` is called
    every control step (the runner's cancel and time-limit watch)."""
    link, watch = session.link, RigWatch(session.link, speed)
    step_s = params.control_step_ms / 1000.0
    limit_rad = min(BRAKE_ARM_LIMIT_RAD, 0.8 * params.servo_range_rad)
    session.command("k0")
    started = deadline = time.monotonic()
    target_rad, window, centred = None, [], False
    wanted = max(2, round(STILL_S / step_s))
    swing, least_swing_rad = Swing(round(SWING_S / step_s)), math.inf
    while (time.monotonic() - started) * speed < limit_s:
        check()
        watch.check()
        newest = link.newest
        observation = newest.received.observation
        if target_rad is None:
            target_rad = params.servo_counts_to_rad(observation.servo_counts)
        window = (window + [observation.position_counts])[-wanted:]
        still = len(window) == wanted and spread_counts(window, params.encoder_counts) <= STILL_COUNTS
        if centred and still:
            return (time.monotonic() - started) * speed
        if not centred and still and abs(target_rad) <= CENTRED_RAD:
            centred, target_rad, window = True, 0.0, []  # the last hair to the centre, then still again
        angle_rad = observation.position_counts * 2 * math.pi / params.encoder_counts
        amplitude_rad = swing.update(angle_rad)
        if amplitude_rad is not None:
            least_swing_rad = min(least_swing_rad, amplitude_rad)
            if not centred and amplitude_rad > least_swing_rad + PUMPED_RAD:
                centred, target_rad, window = True, 0.0, []  # pumping, not braking: hold at the centre instead
        fresh = (time.monotonic() - newest.receive_time_s) * speed <= STALE_STEPS * step_s
        if not centred and fresh:
            velocity_rad_s = observation.omega_rev_s * 2 * math.pi
            rate = brake_rate_rad_s(angle_rad, velocity_rad_s, target_rad, params.pendulum_natural_frequency_rad_s)
            target_rad = max(-limit_rad, min(limit_rad, target_rad + rate * step_s))
        session.command(f"b{target_rad / params.servo_range_rad:.4f}")
        deadline += step_s / speed
        time.sleep(max(0.0, deadline - time.monotonic()))
    session.command("b0")
    raise RigFault(f"rig {link.rig}'s pendulum did not hang still within {limit_s:g} s of braking and holding "
                   f"(spread {spread_counts(window, params.encoder_counts)} counts over the last {STILL_S:g} s): "
                   "check the bearing and the encoder")
