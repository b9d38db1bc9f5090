"""A judged job's episodes on a rig, driven over its `RigSession` at the rig's speed: the uploaded controller run
by the device from a pendulum hanging still, each control step sampled (time, angle, servo, flags). (An
excitation job's episodes: `pendkit.adapt.queued`, above this layer.)

While the device's controller runs, the rig's own stops act on it; the queue stops a job whose controller keeps
one of them busy (`SAFETY_SHARE` of the last seconds): a pendulum spun past the over-spin limit, an arm driven
against its end stops.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from pendkit.device.commands import INTEGER_SETTINGS
from pendkit.queue.rig_reset import JobStopped, RigWatch, reset_rig
from pendkit.rig import RigParams

# The share of the last SAFETY_WINDOW_S (rig seconds) a stop may be set by the job's controller before the queue
# stops the job: the energy swing-up peaks at 1.6 rev/s (under the 2 rev/s limit) and brushes an end stop now and
# then; a bang-bang spinner sits at its end stops 85% of the time and spins past the limit in bursts.
SAFETY_WINDOW_S = 5.0
SAFETY_SHARE = {"overspin": 0.2, "arm_limit": 0.6}
# While the device runs its own controller the host's heartbeat only says the host is still there: a runner's pause
# (the twin's judging in the same process, a busy machine) must not hold the servo mid-swing, while a host gone for
# a second still stops the rig. The host-driven reset keeps the rig's own watchdog (RigParams.watchdog_timeout_ms).
ONBOARD_WATCHDOG_S = 1.0
_, WATCHDOG_MIN_MS, WATCHDOG_MAX_MS = INTEGER_SETTINGS["w"]  # the protocol's own range for `w`
SAFETY_SAID = {"overspin": "the rig's over-spin stop held the servo (the pendulum spun faster than the device allows)",
               "arm_limit": "the controller drove the arm against its end stops"}


@dataclass(frozen=True)
class Sample:
    """One control step of an episode: the device's time since the episode started, the pendulum's angle from
    upright, the servo's counts and the reading's flags."""

    t_s: float
    angle_from_upright_rad: float
    servo_counts: int
    flags: frozenset[str]


def angle_from_upright_rad(position_counts: int, counts: int = 1024) -> float:
    return (position_counts * 2 * math.pi / counts) % (2 * math.pi) - math.pi


class _SafetyShare:
    """How much of the last SAFETY_WINDOW_S each stop was set, over the device's readings by its clock."""

    def __init__(self) -> None:
        self.window: deque[tuple[int, frozenset[str]]] = deque()

    def update(self, millis: int, flags: frozenset[str]) -> None:
        if self.window and millis <= self.window[-1][0]:
            return  # the same reading again (none newer arrived this step): counted once
        self.window.append((millis, flags))
        if millis - self.window[0][0] < SAFETY_WINDOW_S * 1000:
            return  # not a whole window yet
        while millis - self.window[0][0] > SAFETY_WINDOW_S * 1000:
            self.window.popleft()
        for name, most in SAFETY_SHARE.items():
            share = sum(name in seen for _, seen in self.window) / len(self.window)
            if share > most:
                raise JobStopped(f"{SAFETY_SAID[name]} {share:.0%} of {SAFETY_WINDOW_S:g} s: stopped, the servo holds")


def watchdog_command(wall_s: float, speed: float) -> str:
    """The `w` command giving a rig `speed` times faster than real time a watchdog of `wall_s` of this host's
    time (its own time runs `speed` times faster), within the protocol's range."""
    return f"w{min(WATCHDOG_MAX_MS, max(WATCHDOG_MIN_MS, round(wall_s * 1000.0 * speed)))}"


def start_controller(session, check: Callable[[], None], attempts: int = 20) -> None:
    """`k1` until the rig says its controller runs."""
    for _ in range(attempts):
        check()
        session.command("k1")
        if session.status(wait_s=0.5, asks=1).get("controller", {}).get("running"):
            return
    raise JobStopped(f"rig {session.link.rig} never said its controller runs after {attempts} `k1`")


def device_episode(session, params: RigParams, steps: int, step_s: float, speed: float,
                   check: Callable[[], None], into: list[Sample]) -> float:
    """Reset the rig, run the uploaded controller for `steps` control steps of `step_s`, appending a `Sample`
    per step to `into` (kept when the episode is cut short); the reset's rig seconds. `RigFault` when the rig
    is unfit, `JobStopped` when the controller keeps a safety stop busy."""
    reset_s = reset_rig(session, params, speed, check)
    watch, hold, link = RigWatch(session.link, speed), _SafetyShare(), session.link
    session.command(watchdog_command(ONBOARD_WATCHDOG_S, speed))
    try:
        start_controller(session, check)
        first_ms = link.newest.received.observation.millis
        deadline = time.monotonic()
        for _ in range(steps):
            deadline += step_s / speed
            session.command("h")
            time.sleep(max(0.0, deadline - time.monotonic()))
            check()
            watch.check()
            observation = link.newest.received.observation
            into.append(Sample((observation.millis - first_ms) / 1000.0,
                               angle_from_upright_rad(observation.position_counts, params.encoder_counts),
                               observation.servo_counts, observation.flags))
            hold.update(observation.millis, observation.flags)
        session.command("k0")
    finally:
        session.command(watchdog_command(params.watchdog_timeout_ms / 1000.0, speed))
    return reset_s
