"""Lab 03, modelling and system identification: public tests."""

from __future__ import annotations

import math

import numpy as np

from pendkit.grading.core import Diagnosis, Failed, NotGradable, as_number, expect, is_real, raised_name, shown, task
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
    expect(abs(got - 1.18) < 1e-3, message + (half_period_note(got, 1.18) or count_note(got, t, angle)))


def half_period_note(got: float, period_s: float) -> str:
    """Words for a period that came out as half of it: crossings counted in both directions."""
    if abs(got - period_s / 2) < 0.01 * period_s:
        return Diagnosis(": that is half a period; you counted crossings in both directions (count only upward "
                         "ones, negative to positive)")
    return ""


def count_note(got, times_s, angles_rad) -> str:
    """Words for a period that is the span from the first upward crossing to the last divided by the number of
    crossings (one too many: n crossings bound n - 1 periods), interpolated or not; or nothing."""
    if not is_real(got):
        return ""
    for interpolated in (True, False):
        crossings = crossings_by(times_s, angles_rad, interpolate=interpolated)
        n = len(crossings)
        if n > 1 and abs(got - (crossings[-1] - crossings[0]) / n) < 1e-9:
            also = "" if interpolated else "; and interpolate each crossing between the two samples around it"
            return Diagnosis(f": that is the span from the first upward crossing to the last "
                             f"({crossings[-1] - crossings[0]:.4f} s) over the number of crossings, {n}; {n} crossings "
                             f"bound {n - 1} periods, so divide by crossings - 1 (or average the differences between "
                             f"successive crossings){also}")
    return ""


def counted_aside(got, times_s, angles_rad, rule: str, tested: str):
    """Text for a test to pass with, when `got` is right but for the count (a half period, or the span over the
    number of crossings): both are one_crossing_per_period's to score. None otherwise."""
    crossings = crossings_by(times_s, angles_rad, rule)
    n = len(crossings)
    both_ways = np.sort(np.concatenate([crossings, crossings_by(times_s, -np.asarray(angles_rad, float), rule)]))
    if n > 1 and abs(got - (crossings[-1] - crossings[0]) / n) < 1e-9:
        slip = f"the span over {n} crossings instead of {n - 1} periods"
    elif len(both_ways) > 1 and abs(got - float(np.mean(np.diff(both_ways)))) < 1e-6:
        slip = "half a period: crossings counted in both directions"
    else:
        return None
    return f"{tested}; your period is {slip}, which one_crossing_per_period scores"


@period.test(points=1, hint="Interpolate between the samples on either side of each crossing.")
def interpolated_crossings(fn, rng):
    # the interpolation is this test's to score: a count slip (one_crossing_per_period's) passes here, named
    t, angle = _swing(1.183, samples=80, dt=0.06, phase=0.77)  # coarse 60 ms samples, like env steps
    got = as_number(fn(t, angle), "period_from_crossings(t, angle)")
    if abs(got - 1.183) < 2e-3:
        return None
    aside = counted_aside(got, t, angle, TASK_RULE, "each crossing is interpolated right")
    if aside:
        return aside
    message = f"with 60 ms samples the period should still come out as 1.183 s, got {got:.4f}"
    if half_period_note(got, 1.183):
        raise NotGradable(message + ", about half of it (see one_crossing_per_period): this test checks the "
                          "interpolation once each period is counted once")
    if abs(got - period_by(t, angle, interpolate=False)) < 1e-9:
        message += Diagnosis(": without interpolation each crossing is only known to within a sample")
    expect(False, message + count_note(got, t, angle))


@period.test(points=1, hint="With fewer than two upward crossings there is no period: return nan (float('nan')).")
def fewer_than_two_crossings(fn, rng):
    t = np.arange(0.0, 1.0, 0.01)
    for angle, what in [(0.1 + 0.05 * np.sin(6 * t), "a swing that never crosses 0"),
                        (t - 0.505, "a log with one upward crossing")]:
        try:
            got = fn(t, angle)
        except (Failed, NotGradable, NotImplementedError):
            raise
        except Exception as error:  # noqa: BLE001 - the task says what to do instead
            raise Failed(f"for {what} period_from_crossings raised {raised_name(error)} ({error}): with fewer than "
                         "two crossings there is no period; return nan (float('nan')) instead", hint=False) from error
        expect(is_real(got) and math.isnan(got), f"for {what} period_from_crossings should return nan, got "
               f"{shown(got)}: with fewer than two crossings there is no period" + Diagnosis("; return nan "
                                                                                          "(float('nan'))"))


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
            raise Failed(f"{said}; period_from_crossings raised {raised_name(error)} ({error}){note}",
                         hint=False) from error
        raise
    ok = abs(got - 1.2) < 1e-3
    aside = None if ok else counted_aside(got, t, angle, TASK_RULE,
                                          "the crossings at readings of exactly 0.0 are found right")
    if aside:
        return aside
    if half_period_note(got, 1.2):
        raise NotGradable("the period comes out as half of it (see one_crossing_per_period): this test checks "
                          "readings of exactly 0.0 once each period is counted once")
    note = "" if ok else zero_readings_note(fn, got, t, angle, 1.2, 1e-3)
    expect(ok, f"{said}, got {got:.4f}{note}", hint=not note)


@damping.test(points=2, hint="delta = mean of ln(A_k / A_(k+1)); zeta = delta / sqrt(4 pi^2 + delta^2).")
def from_peak_amplitudes(fn, rng):
    for zeta in (0.02, 0.07, 0.3):
        delta = 2 * math.pi * zeta / math.sqrt(1 - zeta**2)
        peaks = 0.5 * np.exp(-delta * np.arange(6))
        got = as_number(fn(peaks), "damping_ratio(peaks)")
        message = (f"peaks decaying by a factor {math.exp(delta):.4f} per cycle mean a damping ratio of {zeta}; "
                   f"got {got:.6g}, off by {got / zeta - 1:+.2%} of the right value")
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


def slew_of(fn, t, command, arm, said: str, expected: float) -> float:
    """The student's slew rate of a log; where it raises, and the same function is right on the log moved to
    start at 0 rad, a failure naming that (`start_note`); else the error as it is."""
    try:
        return as_number(fn(t, command, arm), "slew_rate(t, command, arm)")
    except (Failed, NotGradable, NotImplementedError):
        raise
    except Exception as error:
        note = start_note(fn, t, command, arm, expected)
        if note:
            raise Failed(f"{said}, slew_rate raised {raised_name(error)} ({error})" + note) from error
        raise


@slew.test(points=1, hint="Time the arm (not the command) at 10 % and 90 % of the way; it covers 80 % of the "
                          "step in between.")
def a_ramp_after_a_lag(fn, rng):
    t, command, arm = servo_ramp(3.0, 0.02, 0.2, 0.8, dt_s=0.005)
    got = slew_of(fn, t, command, arm, "for a 3 rad/s ramp from 0.2 to 0.8 rad", 3.0)
    note = slew_note(got, 3.0) or start_note(fn, t, command, arm, 3.0)
    expect(abs(got - 3.0) < 0.01, f"for a 3 rad/s ramp from 0.2 to 0.8 rad, slew_rate should be 3.000 rad/s, got "
                                  f"{got:.4f}" + note)


@slew.test(points=1, hint="The step can go either way: use its size.")
def a_step_the_other_way(fn, rng):
    # the direction is this test's to score: a slew measured from 0 rad (a_ramp_after_a_lag's) passes here, named
    t, command, arm = servo_ramp(2.5, 0.03, 0.3, -0.5, dt_s=0.005)
    got = slew_of(fn, t, command, arm, "for a 2.5 rad/s ramp from 0.3 to -0.5 rad", 2.5)
    if abs(got - 2.5 / 0.8) < 2e-3 * 2.5:
        return ("the step's direction is handled right; your slew is over the whole step rather than 80 % of it, "
                "which a_ramp_after_a_lag scores")
    if abs(got - 2.5) >= 0.01 and not slew_note(got, 2.5):
        note = start_note(fn, t, command, arm, 2.5)
        if note:
            return ("the step's direction is handled right; your slew is measured from 0 rad rather than from the "
                    "arm's start, which a_ramp_after_a_lag scores" + note)
    expect(abs(got - 2.5) < 0.01, _slew_message("for a 2.5 rad/s ramp from 0.3 to -0.5 rad, slew_rate", got, 2.5))


@slew.test(points=1, hint="A log whose command never changes has no step: raise ValueError saying so.")
def a_command_that_never_changes(fn, rng):
    t = np.arange(0.0, 0.5, 0.005)
    command, arm = np.full_like(t, 0.4), 0.4 + 0.001 * np.sin(40 * t)
    try:
        got = fn(t, command, arm)
    except ValueError:
        return None
    except (Failed, NotGradable, NotImplementedError):
        raise
    except Exception as error:  # noqa: BLE001 - the task names the exception
        raise Failed(f"for a log whose command stays at 0.4 rad slew_rate raised {raised_name(error)} ({error}): "
                     "the task asks for ValueError, saying there is no step to measure", hint=False) from error
    expect(False, f"for a log whose command stays at 0.4 rad slew_rate returned {shown(got)}"
           + Diagnosis(": there is no step to measure; raise ValueError saying so"))


def slew_without_interpolation(t, command, arm) -> set[float]:
    """What the slew comes to when each crossing is taken at a sample (the first at or past the level, or
    the last before it), without interpolating."""
    k = int(np.argmax(command != command[0]))
    progress = (arm[k:] - arm[k - 1]) / (command[k] - arm[k - 1])
    times, step = t[k:], abs(command[k] - arm[k - 1])
    after = [times[int(np.argmax(progress >= level))] for level in (0.1, 0.9)]
    before = [times[int(np.argmax(progress >= level)) - 1] for level in (0.1, 0.9)]
    return {0.8 * step / (b - a) for a, b in (after, before) if b > a}


def slew_with_the_wrong_pair(t, command, arm) -> float:
    """The slew when each crossing is interpolated between the first sample at or past the level and the one
    after it (rather than the last sample before it and the first at or past it)."""
    k = int(np.argmax(command != command[0]))
    progress, times = (arm[k:] - arm[k - 1]) / (command[k] - arm[k - 1]), t[k:]

    def crossing(level):
        i = int(np.argmax(progress >= level))
        if i + 1 >= len(progress) or progress[i + 1] == progress[i]:
            return times[i]
        return times[i] + (level - progress[i]) * (times[i + 1] - times[i]) / (progress[i + 1] - progress[i])

    return 0.8 * abs(command[k] - arm[k - 1]) / (crossing(0.9) - crossing(0.1))


def interpolation_note(got, t, command, arm) -> str:
    """Words for a slew whose crossings are taken at a sample, or interpolated between the wrong pair of
    samples, on this log; or nothing."""
    if not is_real(got):
        return ""
    if any(abs(got - plain) < 1e-6 for plain in slew_without_interpolation(t, command, arm)):
        return Diagnosis(": that is each crossing taken at a sample, without interpolation: interpolate between the "
                         "two samples around it")
    if abs(got - slew_with_the_wrong_pair(t, command, arm)) < 1e-6:
        return Diagnosis(": each crossing is interpolated between the first sample at or past the level and the one "
                         "after it; interpolate between the two samples around it (the last below the level and the "
                         "first at or past it)")
    return ""


@slew.test(points=1, hint="Interpolate each crossing between the two samples around it.")
def coarse_samples(fn, rng):
    # the interpolation is this test's to score: a sign or an 80 % slip (the other tests') passes here, named
    t, command, arm = servo_ramp(3.3, 0.013, 0.0, 0.7, dt_s=0.02, step_at_s=0.107)
    got = as_number(fn(t, command, arm), "slew_rate(t, command, arm)")
    if abs(got - 3.3) >= 0.01 and slew_note(got, 3.3):
        return f"each crossing is interpolated right; your slew{slew_note(got, 3.3)} (a_ramp_after_a_lag scores it)"
    message = f"with 20 ms samples a 3.3 rad/s ramp should still give 3.300 rad/s, got {got:.4f}"
    expect(abs(got - 3.3) < 0.01, message + interpolation_note(got, t, command, arm))


prelab_task("03", ("period_s", "log_decrement",))

written("03.reflection", "Reflection", points=3)
