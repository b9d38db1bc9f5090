"""Lab 03, modelling and system identification: public tests."""

from __future__ import annotations

import math

import numpy as np

from pendkit.grading.core import Diagnosis, Failed, NotGradable, as_number, expect, is_real, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

frequency = task("03.natural_frequency", function="natural_frequency",
                 title="Compound-pendulum frequency", hidden_points=1)
period = task("03.period_from_crossings", function="period_from_crossings",
              title="Period from zero crossings", hidden_points=1)
damping = task("03.damping_ratio", function="damping_ratio", title="Damping from successive peaks", hidden_points=1)

G = 9.81


@frequency.test(points=2, hint="w0 = sqrt(m g l / J), J about the pivot, l from the pivot to the centre of mass.")
def compound_pendulum(fn, rng):
    for mass, com, inertia in [(0.0355, 0.2097, 0.002063), (0.1, 0.5, 0.1 * 0.5**2), (0.02, 0.1, 0.0004)]:
        expected = math.sqrt(mass * G * com / inertia)
        call = f"natural_frequency({mass}, {com}, {inertia})"
        got = as_number(fn(mass, com, inertia), call)
        message = f"{call} should be {expected:.4f} rad/s, got {got:.4f}"
        expect(abs(got - expected) < 1e-6 * expected, message + frequency_note(mass, com, inertia, got))


def frequency_note(mass: float, com: float, inertia: float, got: float) -> str:
    """The cause of a wrong natural frequency, named from its value (a `Diagnosis`), or ""."""
    expected = math.sqrt(mass * G * com / inertia)
    causes = [(expected**2, ": that is w0 squared; take the square root"),
              (expected / (2 * math.pi), ": that is in Hz (cycles per second); the lab wants rad/s"),
              (math.sqrt(G / com), ": that is a point mass on a massless rod; use the inertia J"),
              (1 / expected, ": that is sqrt(J / (m g l)), the ratio upside down: w0 = sqrt(m g l / J)"),
              (2 * math.pi / expected, ": that is the period 2 pi / w0 in seconds; the lab wants w0 in rad/s")]
    for value, cause in causes:
        if abs(got - value) < 1e-6 * value:
            return Diagnosis(cause)
    return ""


def _swing(period_s: float, samples: int = 1000, dt: float = 0.005, phase: float = 0.3):
    t = np.arange(samples) * dt
    return t, 0.4 * np.sin(2 * math.pi * t / period_s + phase)


@period.test(points=1, hint="Use only upward crossings (negative to positive): one per period.")
def one_crossing_per_period(fn, rng):
    t, angle = _swing(1.18)
    got = as_number(fn(t, angle), "period_from_crossings(t, angle)")
    message = f"for a 1.18 s swing the period should be 1.180 s, got {got:.4f}"
    expect(abs(got - 1.18) < 1e-3, message + half_period_note(got, 1.18))


def half_period_note(got: float, period_s: float) -> str:
    """Words for a period that came out as half of it: crossings counted in both directions."""
    if abs(got - period_s / 2) < 0.01 * period_s:
        return Diagnosis(": that is half a period; you counted crossings in both directions (count only upward "
                         "ones, negative to positive)")
    return ""


@period.test(points=2, hint="Interpolate between the samples on either side of each crossing.")
def interpolated_crossings(fn, rng):
    t, angle = _swing(1.183, samples=80, dt=0.06, phase=0.77)  # coarse 60 ms samples, like env steps
    got = as_number(fn(t, angle), "period_from_crossings(t, angle)")
    if abs(got - 1.183 / 2) < 0.05:
        raise NotGradable("the period comes out as half of it (see one_crossing_per_period): this test checks "
                          "the interpolation once each period is counted once")
    expect(abs(got - 1.183) < 2e-3, f"with 60 ms samples the period should still come out as 1.183 s, got "
           f"{got:.4f}: without interpolation each crossing is only known to within a sample")


COUNT_RAD = 2 * math.pi / 1024  # one encoder count


def floored_swing(period_s: float = 1.2, amplitude_rad: float = 0.05, decay_per_s: float = 0.3,
                  phase_rad: float = 0.2, dt_s: float = 0.025, duration_s: float = 6.0):
    """A swing dying away, read as the encoder reads it: each angle floored to a whole count (0.0 for every
    angle in [0, 1 count)), so many readings are exactly 0.0."""
    t = np.arange(0.0, duration_s, dt_s)
    angle = amplitude_rad * np.exp(-decay_per_s * t) * np.sin(2 * math.pi * t / period_s + phase_rad)
    return t, np.floor(angle / COUNT_RAD) * COUNT_RAD


# A crossing by the task's rule (below 0, then at or above 0) and the two slips at readings of exactly 0.0
TASK_RULE = "a[i] < 0 <= a[i+1]"
CROSSING_RULES = {TASK_RULE: lambda a: (a[:-1] < 0) & (a[1:] >= 0),
                  "a[i] < 0 < a[i+1]": lambda a: (a[:-1] < 0) & (a[1:] > 0),
                  "a[i] <= 0 < a[i+1]": lambda a: (a[:-1] <= 0) & (a[1:] > 0)}


def crossings_by(times_s, angles_rad, rule: str = TASK_RULE, interpolate: bool = True) -> np.ndarray:
    """The upward crossings' times by `rule` (a key of CROSSING_RULES): interpolated between the samples around
    each, or (not) the sample after it."""
    t, a = np.asarray(times_s, dtype=float), np.asarray(angles_rad, dtype=float)
    up = np.nonzero(CROSSING_RULES[rule](a))[0]
    if not interpolate:
        return t[up + 1]
    return t[up] - a[up] * (t[up + 1] - t[up]) / (a[up + 1] - a[up])


def period_by(times_s, angles_rad, rule: str = TASK_RULE, interpolate: bool = True) -> float:
    """The mean period from the upward crossings by `rule`; nan with fewer than two crossings."""
    crossings = crossings_by(times_s, angles_rad, rule, interpolate)
    return float(np.mean(np.diff(crossings))) if len(crossings) > 1 else math.nan


def _same(got: float, value: float) -> bool:
    return (math.isnan(got) and math.isnan(value)) or abs(got - value) < 1e-9


def crossing_note(got, times_s, angles_rad) -> str:
    """Words for a period that one of the slips at readings of exactly 0.0 gives on this swing (and the task's
    rule does not), or nothing: crossings through a 0.0 reading skipped, or taken from a 0.0 reading on."""
    if not is_real(got):
        return ""
    got, right = float(got), period_by(times_s, angles_rad)
    a = np.asarray(angles_rad, dtype=float)
    up = np.nonzero(CROSSING_RULES[TASK_RULE](a))[0]
    through_zero = int(np.sum(a[up + 1] == 0.0))
    for interpolated in (True, False):
        skipped, from_zero = (period_by(times_s, angles_rad, rule, interpolated) for rule in list(CROSSING_RULES)[1:])
        also = "" if interpolated else "; and interpolate each crossing between the two samples around it"
        if _same(got, skipped) and not _same(got, right):
            return Diagnosis(f": {through_zero} of this swing's {len(up)} upward crossings reach a reading of exactly "
                             f"0.0, and yours skipped them (a[i] < 0 < a[i+1]): a crossing lies between a sample below "
                             f"0 and the next one at or above 0 ({TASK_RULE}){also}")
        if _same(got, from_zero) and not _same(got, right):
            return Diagnosis(f": your crossings run from a sample at or below 0 to one above 0 (a[i] <= 0 < a[i+1]); "
                             "a reading of exactly 0.0 means the pendulum is already at or past 0 (the encoder "
                             "floors), so a crossing lies between a sample below 0 and the next one at or above 0 "
                             f"({TASK_RULE}){also}")
    return ""


def zero_readings_note(fn, got, times_s, angles_rad, expected_s: float, tolerance_s: float) -> str:
    """Why a period that is wrong on this swing went wrong at its readings of exactly 0.0, or nothing: a slip named
    from its value (`crossing_note`), else, when the same function gets the period right once every 0.0 reading
    is moved a hair above 0, that those readings are what it gets wrong. `got`: None where the function raised."""
    note = "" if got is None else crossing_note(got, times_s, angles_rad)
    angles = np.asarray(angles_rad, dtype=float)
    if note or not np.any(angles == 0.0):
        return note
    try:
        nudged = float(fn(times_s, np.where(angles == 0.0, 1e-9, angles)))
    except Exception:  # noqa: BLE001 - then the 0.0 readings are not shown to be the cause
        return ""
    if abs(nudged - expected_s) < tolerance_s:
        return Diagnosis(f": with every reading of exactly 0.0 moved a hair above 0 your function gives "
                         f"{nudged:.4f} s, so the 0.0 readings are what it gets wrong: a crossing lies between a "
                         f"sample below 0 and the next one at or above 0 ({TASK_RULE})")
    return ""


@period.test(points=1, hint="A reading of exactly 0.0 means the pendulum is at or past 0: a crossing lies between a "
                            "sample below 0 and the next one at or above 0.")
def readings_of_exactly_zero(fn, rng):
    t, angle = floored_swing()
    zeros = int(np.sum(angle == 0.0))
    said = (f"for a 1.2 s swing read through the encoder (each angle floored to a whole count, so {zeros} of its "
            f"{len(t)} readings are exactly 0.0) the period should be 1.2000 s")
    try:
        got = as_number(fn(t, angle), "period_from_crossings(t, angle)")
    except (Failed, NotGradable, NotImplementedError):
        raise
    except Exception as error:  # noqa: BLE001 - named below when the 0.0 readings explain it, else shown as it is
        note = zero_readings_note(fn, None, t, angle, 1.2, 1e-3)
        if note:
            raise Failed(f"{said}; period_from_crossings raised {type(error).__name__} ({error}){note}",
                         hint=False) from error
        raise
    if half_period_note(got, 1.2):
        raise NotGradable("the period comes out as half of it (see one_crossing_per_period): this test checks "
                          "readings of exactly 0.0 once each period is counted once")
    ok = abs(got - 1.2) < 1e-3
    note = "" if ok else zero_readings_note(fn, got, t, angle, 1.2, 1e-3)
    expect(ok, f"{said}, got {got:.4f}{note}", hint=not note)


@damping.test(points=2, hint="delta = mean of ln(A_k / A_(k+1)); zeta = delta / sqrt(4 pi^2 + delta^2).")
def from_peak_amplitudes(fn, rng):
    for zeta in (0.02, 0.07, 0.3):
        delta = 2 * math.pi * zeta / math.sqrt(1 - zeta**2)
        peaks = 0.5 * np.exp(-delta * np.arange(6))
        got = as_number(fn(peaks), "damping_ratio(peaks)")
        message = (f"peaks decaying by a factor {math.exp(delta):.4f} per cycle mean a damping ratio of {zeta}; "
                   f"got {got:.6g} ({got / zeta - 1:+.2%})")
        expect(abs(got - zeta) < 1e-6, message + damping_note(got, zeta))


def damping_note(got: float, zeta: float) -> str:
    """Words for a damping ratio that a known mistake gives for true ratio `zeta`, or nothing."""
    delta = 2 * math.pi * zeta / math.sqrt(1 - zeta**2)
    if abs(got + zeta) < 1e-6:
        return Diagnosis(": a negative damping ratio: the ratio is upside down; delta = ln(A_k / A_(k+1)), each "
                         "peak over the next (smaller) one")
    if abs(got - delta) < 1e-6:
        return Diagnosis(": that is the logarithmic decrement itself; convert it to a damping ratio")
    if abs(got - delta / (2 * math.pi)) < 1e-9:
        return Diagnosis(": delta / 2 pi is only right for light damping; use delta / sqrt(4 pi^2 + delta^2)")
    if abs(got - zeta * math.log(10)) < 1e-3 or abs(got - zeta / math.log(10)) < 1e-3:
        return Diagnosis(": use the natural logarithm (np.log), not log10")
    return ""


slew = task("03.slew_rate", function="slew_rate", title="Servo slew rate from a step log", hidden_points=2)


def servo_ramp(slew_rad_s: float, lag_s: float, start_rad: float, target_rad: float, dt_s: float,
               step_at_s: float = 0.1, duration_s: float = 0.8):
    """A step log: the command jumps at `step_at_s`; the arm waits `lag_s`, then moves at `slew_rad_s`."""
    t = np.arange(0.0, duration_s, dt_s)
    command = np.where(t >= step_at_s, target_rad, start_rad)
    moved = np.clip((t - step_at_s - lag_s) * slew_rad_s, 0.0, abs(target_rad - start_rad))
    arm = start_rad + np.sign(target_rad - start_rad) * moved
    return t, command, arm


def _slew_message(call: str, got: float, expected: float) -> str:
    return f"{call} should be {expected:.3f} rad/s, got {got:.4f}" + slew_note(got, expected)


def slew_note(got, expected: float) -> str:
    """Words for the slew mistakes that any step log shows the same way (a sign, the 80 %), or nothing."""
    if not is_real(got):
        return ""
    if abs(got + expected) < 1e-3 * expected:
        return Diagnosis(": a speed is positive whichever way the arm moves (use the size of the step)")
    if abs(got - expected / 0.8) < 2e-3 * expected:
        return Diagnosis(": between 10 % and 90 % the arm covers 80 % of the step, not all of it")
    return ""


def start_note(fn, t, command, arm, expected: float) -> str:
    """Words for a slew measured from 0 rad rather than from the arm's start: right on the same log moved to
    start at 0, wrong on this one (which starts elsewhere); or nothing."""
    start = float(arm[int(np.argmax(command != command[0])) - 1])
    try:
        from_zero = float(fn(t, command - start, arm - start))
    except Exception:  # noqa: BLE001 - any other failure is the test's own to report
        return ""
    if not start or not abs(from_zero - expected) < 0.01 * expected:
        return ""
    return Diagnosis(f": right for the same step moved to start at 0 rad, wrong for this one from {start:g} rad: "
                     "measure the 10 % and 90 % from the arm's start (its angle just before the command "
                     "changes), not from 0")


@slew.test(points=2, hint="Time the arm (not the command) at 10 % and 90 % of the way; it covers 80 % of the "
                          "step in between.")
def a_ramp_after_a_lag(fn, rng):
    t, command, arm = servo_ramp(3.0, 0.02, 0.2, 0.8, dt_s=0.005)
    got = as_number(fn(t, command, arm), "slew_rate(t, command, arm)")
    note = slew_note(got, 3.0) or start_note(fn, t, command, arm, 3.0)
    expect(abs(got - 3.0) < 0.01, f"for a 3 rad/s ramp from 0.2 to 0.8 rad, slew_rate should be 3.000 rad/s, got "
                                  f"{got:.4f}" + note)


@slew.test(points=1, hint="The step can go either way: use its size.")
def a_step_the_other_way(fn, rng):
    t, command, arm = servo_ramp(2.5, 0.03, 0.3, -0.5, dt_s=0.005)
    got = as_number(fn(t, command, arm), "slew_rate(t, command, arm)")
    expect(abs(got - 2.5) < 0.01, _slew_message("for a 2.5 rad/s ramp from 0.3 to -0.5 rad, slew_rate", got, 2.5))


def _slew_without_interpolation(t, command, arm) -> set[float]:
    """What the slew comes to when each crossing is taken at a sample (the first at or past the level, or
    the last before it), without interpolating."""
    k = int(np.argmax(command != command[0]))
    progress = (arm[k:] - arm[k - 1]) / (command[k] - arm[k - 1])
    times, step = t[k:], abs(command[k] - arm[k - 1])
    after = [times[int(np.argmax(progress >= level))] for level in (0.1, 0.9)]
    before = [times[int(np.argmax(progress >= level)) - 1] for level in (0.1, 0.9)]
    return {0.8 * step / (b - a) for a, b in (after, before) if b > a}


@slew.test(points=1, hint="Interpolate each crossing between the two samples around it.")
def coarse_samples(fn, rng):
    t, command, arm = servo_ramp(3.3, 0.013, 0.0, 0.7, dt_s=0.02, step_at_s=0.107)
    got = as_number(fn(t, command, arm), "slew_rate(t, command, arm)")
    message = f"with 20 ms samples a 3.3 rad/s ramp should still give 3.300 rad/s, got {got:.4f}"
    if slew_note(got, 3.3):  # the same mistake as on a fine log: named as there, without this test's hint
        raise NotGradable(message + slew_note(got, 3.3))
    if any(abs(got - plain) < 1e-6 for plain in _slew_without_interpolation(t, command, arm)):
        message += Diagnosis(": that is each crossing taken at a sample, without interpolation")
    else:
        message += ": with samples this coarse, check how each crossing is located between the two samples " \
                   "around it (the level minus the earlier sample's progress, over the pair's difference)"
    expect(abs(got - 3.3) < 0.01, message)


prelab_task("03", ("period_s", "log_decrement",))

written("03.reflection", "Reflection", points=3)
