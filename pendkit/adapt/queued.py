"""`pendkit adapt`'s excitation as a queue job: the episodes `pendkit.adapt.excitation.record` records on an
env, driven instead over a queue runner's `RigSession` at the rig's speed, each from rest after the queue's
unattended reset, and checked as `pendkit adapt` checks its recordings before handing them back.
`pendkit queue run` gives `record_excitation` to its runner (the queue sits below adapt in the kit's layers).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable

from pendkit.adapt.excitation import ADAPT_FREE_STEPS, EXCITATION_STREAM, Excitation, Recording, schedule
from pendkit.adapt.recording_checks import check_recordings
from pendkit.adapt.replay import trace_from_log
from pendkit.errors import RecordingError
from pendkit.queue.rig_episodes import Sample, angle_from_upright_rad
from pendkit.queue.rig_reset import JobStopped, RigWatch, reset_rig
from pendkit.rig import RigParams
from pendkit.telemetry.log import LogRecord


def record_excitation(session, params: RigParams, speed: float, spec: dict, check: Callable[[], None],
                      runs: list, recordings: list[Recording]) -> None:
    """The excitation job `spec` (its `episodes` and `loop_episodes`) on the rig behind `session` (its
    firmware's servo in `params`), each episode's samples appended to `runs` and its recording to `recordings`
    as it goes (kept when cut short); the recordings are checked at the end (`JobStopped` with the reason)."""
    streamed = dataclasses.replace(params, **EXCITATION_STREAM)
    link = session.link
    link.log = log = ScaledLog(speed)
    try:
        excitation_stream(session, streamed, on=True)
        for excitation in schedule(spec["episodes"], spec["loop_episodes"], ADAPT_FREE_STEPS):
            samples: list[Sample] = []
            runs.append(samples)
            recordings.append(excitation_episode(session, excitation, streamed, speed, check, log, samples))
    finally:
        link.log = None
        excitation_stream(session, params, on=False)
    try:
        check_recordings(recordings, params)
    except RecordingError as error:
        raise JobStopped(str(error)) from None


class ScaledLog:
    """An in-memory episode log on the rig's time: the host's clock scaled by the rig's speed, so that a virtual
    rig run faster than real time keeps the device's time (`pendkit.adapt.recording_checks` holds the two
    together). The link writes every message here (`RigLink.log`)."""

    def __init__(self, speed: float) -> None:
        self.speed, self.origin_s = speed, time.monotonic()
        self.records: list[LogRecord] = []

    def write(self, t_s: float, direction: str, topic: str, payload: str) -> None:
        self.records.append(LogRecord(self.origin_s + (t_s - self.origin_s) * self.speed, direction, topic, payload))

    def flush(self) -> None:
        pass


def excitation_episode(session, excitation: Excitation, params: RigParams, speed: float,
                       check: Callable[[], None], log: ScaledLog, into: list[Sample]) -> Recording:
    """One excitation episode from rest (the arm braked and centred until the pendulum hangs still), its targets
    sent as continuous commands every control step; the `Recording` `pendkit adapt` makes, with the device's
    trace from `log` (attached to the session's link)."""
    step_s = params.control_step_ms / 1000.0
    rest_s = reset_rig(session, params, speed, check)
    watch, link = RigWatch(session.link, speed), session.link
    start = link.newest.received.observation
    recording = Recording(excitation.actions(), params.servo_counts_to_rad(start.servo_counts),
                          start.position_counts * 2 * math.pi / params.encoder_counts,
                          rest_steps=round(rest_s / step_s))
    logged_before = len(log.records)
    deadline = time.monotonic()
    for action in recording.actions:
        session.command(f"b{action:.4f}")
        deadline += step_s / speed
        time.sleep(max(0.0, deadline - time.monotonic()))
        check()
        watch.check()
        observation = link.newest.received.observation
        recording.pendulum_rad.append(observation.position_counts * 2 * math.pi / params.encoder_counts)
        recording.pendulum_velocity_rad_s.append(observation.omega_rev_s * 2 * math.pi)
        into.append(Sample((observation.millis - start.millis) / 1000.0,
                           angle_from_upright_rad(observation.position_counts, params.encoder_counts),
                           observation.servo_counts, observation.flags))
    recording.device = trace_from_log(log.records, logged_before, params.encoder_counts)
    return recording


def excitation_stream(session, params: RigParams, on: bool) -> None:
    """Ask the device for the excitation's stream (a reading every 10 ms, a short velocity window) and no
    device filter; `on=False` gives it back the rig's usual stream."""
    stream = EXCITATION_STREAM if on else {"streaming_period_ms": params.streaming_period_ms,
                                           "velocity_mean_window": params.velocity_mean_window}
    session.command(f"u{round(stream['streaming_period_ms'])}")
    session.command(f"n{stream['velocity_mean_window']}")
    session.command("e0")
