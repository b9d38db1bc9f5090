"""Recordings checked before identification (issue 72, part 5).

Identification fits a twin to whatever it is given: from an encoder that never moved it fits a pendulum that
never swings, and a rig.json, a policy and two controller blobs follow. So every excitation recording is
checked first, one check per thing a healthy recording must show, and the first that fails refuses it with a
`RecordingError` whose one line names the sensor or the clock and what to check on the rig. Thresholds come
from the encoder's resolution and the rig's physics (`RigParams`), never from one recording: a healthy twin's
recording and a virtual rig's behind a classroom's WiFi (losses, jitter) pass.

What each reads: the host's view, one reading per control step (`Recording.pendulum_rad`, wrapped into
[0, 2 pi) by design, its times unknown), and the device's own trace (`Recording.device`: every reading on the
device's clock, the laptop's arrival times, the servo counts the device applied). A jump of the encoder and the
clocks can only be judged on the device's trace; the host's view is checked for what it can show alone.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from pendkit.adapt.excitation import CENTRE, EXCITATION_STREAM, Excitation, Recording, record
from pendkit.adapt.identify import SERVO_BOUNDS
from pendkit.encoder import wrapped_rad
from pendkit.errors import RecordingError
from pendkit.link.driver import CLOCK_SLACK_S
from pendkit.rig import RigParams

STILL_FLICKER_COUNTS = 1  # a still encoder may flicker by a count; one that never moves further is stuck
QUANTISATION_COUNTS = 2  # two readings, each floored to its count: their difference is off by less than 2
SERVO_ROUNDING_COUNTS = 1  # the device rounds each target to a whole count (and the host sends 4 decimals)

# (field, what it is on the rig, what to check) for the numbers a recording carries
HOST_FIELDS = (("pendulum_rad", "the encoder's angle", "is the encoder's cable seated?"),
               ("pendulum_velocity_rad_s", "the encoder's rate", "is the encoder's cable seated?"),
               ("actions", "the servo targets sent", "record again (the excitation sent no numbers)"))
START_FIELDS = (("start_pendulum_rad", "the encoder's reading at rest", "is the encoder's cable seated?"),
                ("start_servo_target_rad", "the servo's target at the start", "restart the rig"))
DEVICE_FIELDS = (("ms", "the device's clock", "reflash the rig's firmware"),
                 ("host_ms", "the laptop's clock in the log", "record again"),
                 ("pendulum_rad", "the encoder's angle on the device's clock", "is the encoder's cable seated?"))


def max_pendulum_speed_rad_s(params: RigParams) -> float:
    """The fastest the pendulum can turn on any rig identification may find from `params` (the fastest servo and
    the shortest pendulum its search allows, `SERVO_BOUNDS`): at the device's over-spin limit, where it stops
    driving the arm, and falling from upright (energy: speed^2 = limit^2 + (2 omega_n)^2), plus the most one
    reversal of the arm at the servo's full speed adds (m l r / J times twice that speed: the pendulum's share of
    the arm's momentum, from the Furuta pendulum's coupling term)."""
    short = params.with_dowel_length(params.dowel_length_m * SERVO_BOUNDS["dowel_length_m"][0])
    arm_rad_s = params.servo_speed_rad_s / SERVO_BOUNDS["servo_speed_s_per_60deg"][0]
    coupling = (short.pendulum_mass_kg * short.pendulum_com_from_pivot_m * short.pivot_radius_m
                / short.pendulum_inertia_about_pivot_kg_m2)
    falling = math.hypot(2 * math.pi * params.overspin_limit_rev_s, 2 * short.pendulum_natural_frequency_rad_s)
    return falling + coupling * 2 * arm_rad_s


def longest_unseen_s(params: RigParams) -> float:
    """A quarter of the shortest swing identification may find: readings further apart than this can miss a
    swing's peak, and the twin cannot be matched across the gap."""
    short = params.with_dowel_length(params.dowel_length_m * SERVO_BOUNDS["dowel_length_m"][0])
    return 2 * math.pi / short.pendulum_natural_frequency_rad_s / 4


def _refuse(trial: int, reason: str) -> RecordingError:
    return RecordingError(f"recording refused, trial {trial}: {reason}")


def _times(count: int) -> str:
    return "once" if count == 1 else f"{count} times"


def _trial_s(recording: Recording, params: RigParams) -> float:
    return len(recording.actions) * params.control_step_ms / 1000


def _device_s(recording: Recording, index: int) -> float:
    """Seconds into the trial of the device's reading `index` (its own clock)."""
    ms = recording.device.ms
    return (ms[index] - ms[0]) / 1000


def check_numbers(recording: Recording, params: RigParams, trial: int) -> None:
    """Every number the recording carries is finite (a NaN angle turns every matching cost into NaN)."""
    step_s = params.control_step_ms / 1000
    arrays = [(np.asarray(getattr(recording, name), dtype=float), what, fix, lambda k: f"step {k + 1}, "
               f"{(k + 1) * step_s:.2f} s in") for name, what, fix in HOST_FIELDS]
    arrays += [(np.asarray([getattr(recording, name)], dtype=float), what, fix, lambda k: "the start")
               for name, what, fix in START_FIELDS]
    if recording.device is not None:
        arrays += [(np.asarray(getattr(recording.device, name), dtype=float), what, fix,
                    lambda k: f"reading {k}") for name, what, fix in DEVICE_FIELDS]
    for values, what, fix, where in arrays:
        broken = np.nonzero(~np.isfinite(values))[0]
        if broken.size:
            kind = "NaN" if np.isnan(values[broken[0]]) else "infinite"
            raise _refuse(trial, f"{what} is {kind} in {broken.size} of {values.size} readings (first at "
                                 f"{where(int(broken[0]))}): {fix}")


def check_readings_arrived(recording: Recording, params: RigParams, trial: int) -> None:
    """Some of the device's readings reached the laptop during the trial."""
    trace = recording.device
    if trace is None or len(trace.ms) < 3:
        raise _refuse(trial, "no reading of the device reached the laptop during it (the link lost them all): is "
                             "the rig on the classroom's WiFi and streaming? check its WiFi and the broker")


def check_no_gap(recording: Recording, params: RigParams, trial: int) -> None:
    """No gap between the device's readings in which the pendulum could swing unseen (`longest_unseen_s`); after
    the clock's checks, so that a gap is readings the link lost, not a clock that jumped."""
    trace = recording.device
    steps_ms = np.diff(trace.ms)
    widest = int(np.argmax(steps_ms))
    limit_s = longest_unseen_s(params)
    if steps_ms[widest] / 1000 > limit_s:
        raise _refuse(trial, f"the link lost every reading for {steps_ms[widest]:.0f} ms "
                             f"({_device_s(recording, widest):.2f} s in), longer than the {limit_s * 1000:.0f} ms "
                             "in which the pendulum can swing unseen: check the rig's WiFi signal, then record again")


def check_clock_runs_forward(recording: Recording, params: RigParams, trial: int) -> None:
    """The device's clock only ever moved forward (a clock that went back is a device that restarted)."""
    trace = recording.device
    ms = np.asarray(trace.ms)
    back = [(float(ms[k]), float(ms[k + 1])) for k in np.nonzero(np.diff(ms) < 0)[0]]
    back = list(trace.clock_back_ms) + back  # gone back in the log (those readings not kept), or here
    if back:
        raise _refuse(trial, f"the device's clock went backwards {_times(len(back))} (first from {back[0][0]:.0f} "
                             f"ms to {back[0][1]:.0f} ms): the rig restarted mid-recording? check its power supply (a "
                             "stalled servo can brown the board out), then record again")


def check_clock_keeps_time(recording: Recording, params: RigParams, trial: int) -> None:
    """The device's clock kept the laptop's time: no step of it further ahead than the laptop's clock moved,
    beyond the network's jitter (`CLOCK_SLACK_S`, the link's own rule), and over the trial as much as the
    laptop's (or, without the laptop's times, about the trial's length)."""
    trace = recording.device
    device_ms = np.asarray(trace.ms)
    slack_ms = CLOCK_SLACK_S * 1000
    if len(trace.host_ms) == len(trace.ms):
        host_ms = np.asarray(trace.host_ms)
        ahead_ms = np.diff(device_ms) - np.diff(host_ms)
        jumps = np.nonzero(ahead_ms > slack_ms)[0]
        if jumps.size:
            first = int(jumps[0])
            raise _refuse(trial, f"the device's clock jumped {ahead_ms[first]:.0f} ms ahead of the laptop's "
                                 f"{_times(jumps.size)} (first {_device_s(recording, first):.2f} s in): a device "
                                 "clock that jumps (its firmware), or a virtual rig run faster than real time "
                                 "(--speed): reflash or restart the rig")
        laptop_s = (host_ms[-1] - host_ms[0]) / 1000
        known = "of the laptop's"
    else:
        laptop_s = _trial_s(recording, params)
        known = "that the trial lasted"
    device_s = (device_ms[-1] - device_ms[0]) / 1000
    if abs(device_s - laptop_s) > CLOCK_SLACK_S + params.control_step_ms / 1000:
        raise _refuse(trial, f"the device's clock ran {device_s:.1f} s in the {laptop_s:.1f} s {known}: a device "
                             "clock that jumps or stalls, or a virtual rig run faster than real time (--speed): "
                             "reflash or restart the rig")


def check_servo_moved(recording: Recording, params: RigParams, trial: int) -> None:
    """The device moved the servo's target when the excitation's targets changed."""
    trace, actions = recording.device, np.asarray(recording.actions)
    counts = np.asarray(trace.servo_counts)
    if np.ptp(actions) > 0 and np.ptp(counts) == 0:
        raise _refuse(trial, f"the device kept the servo at {counts[0]} counts throughout, while targets "
                             f"{actions.min():+.2f}..{actions.max():+.2f} were sent: the commands did not reach "
                             "it, or a safety stop held it (its status flags: watchdog, over-spin, stuck encoder)")


def _encoder_counts(recording: Recording, params: RigParams) -> np.ndarray:
    """The encoder's readings in counts from the first, unwrapped: the device's trace, or the host's view."""
    per_count = 2 * math.pi / params.encoder_counts
    if recording.device is not None:
        angles = np.asarray(recording.device.pendulum_rad)
        return (angles - angles[0]) / per_count
    angles = np.asarray([recording.start_pendulum_rad, *recording.pendulum_rad])
    return np.cumsum(wrapped_rad(np.diff(angles, prepend=angles[0]))) / per_count


def check_encoder_moved(recording: Recording, params: RigParams, trial: int) -> None:
    """The encoder moved more than a still one flickers: every excitation jumps the arm by tens of degrees,
    which swings the pendulum by hundreds of counts."""
    moved = np.ptp(_encoder_counts(recording, params))
    if moved <= STILL_FLICKER_COUNTS:
        at = int(np.floor(wrapped_rad(recording.start_pendulum_rad) * params.encoder_counts / (2 * math.pi)))
        arm_deg = max(abs(a) for a in recording.actions) * params.servo_range_deg
        raise _refuse(trial, f"the encoder stayed at {at % params.encoder_counts} counts for all "
                             f"{_trial_s(recording, params):.1f} s while the arm was sent up to {arm_deg:.0f} deg "
                             "from the centre: is the magnet in place and the encoder's cable seated?")


def check_encoder_jumps(recording: Recording, params: RigParams, trial: int) -> None:
    """No two readings of the device further apart than the pendulum can turn between them
    (`max_pendulum_speed_rad_s`, plus the encoder's quantisation)."""
    trace = recording.device
    angles, ms = np.asarray(trace.pendulum_rad), np.asarray(trace.ms)
    fastest = max_pendulum_speed_rad_s(params)
    steps_rad = np.abs(np.diff(angles))
    allowed_rad = fastest * np.diff(ms) / 1000 + QUANTISATION_COUNTS * 2 * math.pi / params.encoder_counts
    jumps = np.nonzero(steps_rad > allowed_rad)[0]
    if jumps.size:
        first = int(jumps[0])
        raise _refuse(trial, f"the encoder's angle jumped further than the pendulum can turn ({fastest:.0f} rad/s at "
                             f"most on this rig) {_times(jumps.size)} (first {steps_rad[first]:.2f} rad in "
                             f"{ms[first + 1] - ms[first]:.0f} ms, {_device_s(recording, first + 1):.2f} s in): a "
                             "reading that wrapped round (1023 to 0) left unwrapped, or a loose magnet or encoder "
                             "cable")


def _servo_range(params: RigParams) -> str:
    return f"the rig's status reports servo counts {params.servo_min_counts}..{params.servo_max_counts}"


def check_servo_range(recording: Recording, params: RigParams, trial: int) -> None:
    """The servo counts the device applied agree with the range its status reports (the prior's end counts):
    none outside it, none beyond what that range gives the largest target sent, and, when the device applied the
    targets as they came (no more distinct counts than targets), each the count that range gives a target."""
    fix = ("the status misreports the servo's range: check the servo settings the firmware was built with, "
           "reflash, and restart the rig")
    if recording.device is None:
        start_deg = math.degrees(recording.start_servo_target_rad)
        if abs(recording.start_servo_target_rad) > params.servo_range_rad + params.servo_rad_per_count:
            raise _refuse(trial, f"{_servo_range(params)} (+-{params.servo_range_deg:.0f} deg), but the servo's "
                                 f"target read {start_deg:+.0f} deg at the start: {fix}")
        return
    targets = sorted({float(a) for a in recording.actions} | {CENTRE})
    expected = sorted({round(params.servo_centre_counts + t * params.servo_span_counts / 2) for t in targets})
    applied = sorted({int(c) for c in recording.device.servo_counts})
    outside = applied[0] < params.servo_min_counts or applied[-1] > params.servo_max_counts
    beyond = (applied[0] < expected[0] - SERVO_ROUNDING_COUNTS
              or applied[-1] > expected[-1] + SERVO_ROUNDING_COUNTS)
    direct = len(applied) <= len(expected)
    unmatched = direct and any(min(abs(c - e) for e in expected) > SERVO_ROUNDING_COUNTS for c in applied)
    if outside or beyond or unmatched:
        shown = ", ".join(map(str, applied)) if direct else f"{applied[0]}..{applied[-1]}"
        raise _refuse(trial, f"{_servo_range(params)}, but its device applied {shown} counts for targets "
                             f"{', '.join(f'{t:+.2f}' for t in targets)}, which that range puts at "
                             f"{', '.join(map(str, expected))}: {fix}")


HOST_CHECKS: tuple[Callable[[Recording, RigParams, int], None], ...] = (
    check_numbers, check_encoder_moved, check_servo_range)
DEVICE_CHECKS: tuple[Callable[[Recording, RigParams, int], None], ...] = (
    check_numbers, check_readings_arrived, check_clock_runs_forward, check_clock_keeps_time, check_no_gap,
    check_servo_moved, check_encoder_moved, check_encoder_jumps, check_servo_range)


def check_recordings(recordings: Sequence[Recording], params: RigParams, device_clock: bool = True) -> None:
    """Refuse (`RecordingError`, one line) the first recording that fails a check, in the order of `DEVICE_CHECKS`
    (the numbers, then the link and the clock, then the servo and the encoder). `params`: what the rig reported
    of itself (the prior: its servo's end counts). `device_clock`: each recording must carry the device's trace
    (the env logged its messages, as `pendkit adapt` records); without it, only what the host's view shows."""
    if not recordings:
        raise RecordingError("recording refused: no excitation episode was recorded")
    for trial, recording in enumerate(recordings, start=1):
        checks = DEVICE_CHECKS if device_clock or recording.device is not None else HOST_CHECKS
        for check in checks:
            check(recording, params, trial)


def record_checked(rig, excitations: Sequence[Excitation], seed: int = 0,
                   on_episode: Callable[[], None] | None = None) -> tuple[list[Recording], RigParams,
                                                                          dict[str, bytes]]:
    """(a) `excitations` recorded on `rig` (a `pendkit.adapt.session.Rig`) with the device's stream, its logs kept
    in a temporary folder, and every recording checked against what the rig reports of itself (`rig.prior()`)
    before anything is written: a refused one leaves nothing behind. Returns (the recordings, the prior, each
    log's contents by file name, for the caller to keep). `on_episode()` after each recording (a progress bar)."""
    with tempfile.TemporaryDirectory(prefix="pendkit-excitation-") as folder:
        env = rig.make_env(stream=EXCITATION_STREAM, log_dir=folder, held=True, **Excitation.env_kwargs())
        try:
            recordings = []
            for k, excitation in enumerate(excitations):
                recordings.append(record(env, excitation, seed=seed + k))
                if on_episode is not None:
                    on_episode()
        finally:
            env.close()
        logs = {path.name: path.read_bytes() for path in sorted(Path(folder).iterdir()) if path.is_file()}
    prior = rig.prior()
    check_recordings(recordings, prior)
    return recordings, prior, logs
