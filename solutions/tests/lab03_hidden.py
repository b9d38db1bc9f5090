"""Hidden tests for lab 03 (instructor material: never copied into labs/)."""

import math

import numpy as np

from pendkit.grading import Failed, expect, task
from pendkit.grading.core import is_real, raised_name, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab03 import (
    count_note,
    damping_note,
    frequency_note,
    half_period_note,
    interpolation_note,
    period_by,
    slew_note,
    start_note,
    zero_readings_note,
)
from pendkit.rig import RigParams
from pendkit.sim.lab_readings import free_swing_readings

frequency = task("03.natural_frequency", function="natural_frequency", title="Compound-pendulum frequency")
period = task("03.period_from_crossings", function="period_from_crossings", title="Period from zero crossings")
damping = task("03.damping_ratio", function="damping_ratio", title="Damping from successive peaks")


@frequency.test(points=1, hidden=True, hint="The rig's own pendulum (its mass, centre of mass and inertia).")
def the_rigs_own_pendulum(fn, rng):
    p = RigParams()
    args = (p.pendulum_mass_kg, p.pendulum_com_from_pivot_m, p.pendulum_inertia_about_pivot_kg_m2)
    got = fn(*args)
    note = frequency_note(*args, float(got)) if is_real(got) else ""
    expect(is_real(got) and abs(got - p.pendulum_natural_frequency_rad_s) < 1e-6, f"the rig's pendulum should give "
           f"{p.pendulum_natural_frequency_rad_s:.4f} rad/s, got {shown(got)}" + note)


@period.test(points=1, hidden=True, hint="The twin's own small swing, sampled every 25 ms.")
def a_twin_swing(fn, rng):
    readings = free_swing_readings(period_ms=25.0, duration_s=6.0, start_velocity_rad_s=1.0)
    angles = (readings.raw_counts * 2 * math.pi / 1024 + math.pi) % (2 * math.pi) - math.pi
    times = readings.times_ms / 1000
    expected = 2 * math.pi / RigParams().pendulum_natural_frequency_rad_s
    zeros = int(np.sum(angles == 0.0))
    said = (f"the twin's small swing ({zeros} of its {len(times)} readings exactly 0.0) has a period of about "
            f"{expected:.3f} s")
    try:
        got = fn(times, angles)
    except Exception as error:  # noqa: BLE001 - named when the 0.0 readings explain it, else shown as it is
        note = zero_readings_note(fn, None, times, angles, expected, 0.01)
        if note:
            raise Failed(f"{said}; period_from_crossings raised {raised_name(error)} ({error}){note}",
                         hint=False) from error
        raise
    ok = is_real(got) and abs(got - expected) < 0.01
    note = ""
    if not ok and is_real(got):
        note = (half_period_note(float(got), expected) or count_note(float(got), times, angles)
                or zero_readings_note(fn, float(got), times, angles, expected, 0.01))
    expect(ok, f"{said}, got {shown(got)}" + note)


@damping.test(points=1, hidden=True, hint="Average the decrement over all cycles, not just the first.")
def noisy_peaks(fn, rng):
    zeta = 0.07
    delta = 2 * math.pi * zeta / math.sqrt(1 - zeta**2)
    peaks = 0.6 * np.exp(-delta * np.arange(8)) * (1 + 0.002 * rng.standard_normal(8))
    got = fn(peaks)
    measured = log_decrement(peaks) / math.sqrt(4 * math.pi**2 + log_decrement(peaks) ** 2)  # these peaks' own
    note = damping_note(got, measured) if is_real(got) else ""
    if is_real(got) and abs(got + measured) < 1e-6:  # the sign is from_peak_amplitudes' to score
        return ("the decrement is averaged over every cycle; your damping ratio comes out negative (the ratio "
                "A_k / A_(k+1) upside down), which from_peak_amplitudes scores")
    expect(is_real(got) and abs(got - zeta) < 0.003, f"slightly noisy peaks with zeta = 0.07 gave {shown(got)}" + note)


slew = task("03.slew_rate", function="slew_rate", title="Servo slew rate from a step log")


@slew.test(points=1, hidden=True, hint="It must work for any step, lag, speed and sampling.")
def random_ramps(fn, rng):
    from pendkit.grading.suites.lab03 import servo_ramp

    for _ in range(5):
        dt, lag, span = rng.choice([0.005, 0.01]), rng.uniform(0.0, 0.05), rng.uniform(0.4, 0.9)
        speed = rng.uniform(1.5, min(6.0, 0.1 * span / dt))  # a sample between each corner and its crossing
        start = rng.uniform(-0.5, 0.5)
        target = start + rng.choice([-1, 1]) * span
        t, command, arm = servo_ramp(speed, lag, start, target, dt_s=dt, step_at_s=rng.uniform(0.05, 0.2),
                                     duration_s=1.0)
        got = fn(t, command, arm)
        note = slew_note(got, speed) or start_note(fn, t, command, arm, speed)
        note = note or interpolation_note(got, t, command, arm)
        expect(abs(got - speed) < 0.01 * speed, f"a {speed:.2f} rad/s ramp from {start:.2f} to {target:.2f} rad "
               f"sampled every {1000 * dt:.0f} ms gave {shown(got)}" + note)


@slew.test(points=1, hidden=True, hint="Check it on the twin's own servo.")
def the_twins_servo(fn, rng):
    from pendkit.control.sysid import identify_servo_steps
    from pendkit.sim.lab_readings import servo_step_readings

    readings = servo_step_readings(steps_rad=(0.6,), hold_s=0.6)
    t, command, arm = readings.times_s, readings.commanded_rad, readings.arm_rad
    expected = identify_servo_steps(t, command, arm).slew_rate_rad_s  # the kit's own 10-90 % slope
    got = fn(t, command, arm)
    expect(abs(got - expected) < 0.01 * expected, f"the twin's servo stepping 0.6 rad should give "
           f"{expected:.3f} rad/s, got {shown(got)}"
           + (slew_note(got, expected) or interpolation_note(got, t, command, arm)))


prelab_answers("03", {"period_s": 1.185507, "log_decrement": 0.693147}, how={
    "period_s": "a period is one full cycle, 2 pi rad: T = 2 pi / w0 = 2 pi / 5.3 ≈ 1.186 s",
    "log_decrement": "delta = ln(A_k / A_(k+1)) = ln 2 ≈ 0.693 (the natural logarithm)"})


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def slew_rate(t, command, arm, interpolate=True, from_zero=False):
    t, command, arm = (np.asarray(v, dtype=float) for v in (t, command, arm))
    if np.all(command == command[0]):
        raise ValueError("the command never changes: there is no step to measure")
    k = int(np.argmax(command != command[0]))
    start = 0.0 if from_zero else arm[k - 1]
    progress = (arm[k:] - start) / (command[k] - start)
    times = t[k:]

    def crossing(level):
        i = int(np.argmax(progress >= level))
        if not interpolate:
            return times[i]
        return times[i - 1] + (level - progress[i - 1]) * (times[i] - times[i - 1]) / (progress[i] - progress[i - 1])

    return 0.8 * abs(command[k] - start) / (crossing(0.9) - crossing(0.1))


def slew_interpolating_the_wrong_pair(t, command, arm):
    """Interpolates, but between the sample at or past the level and the one after it."""
    t, command, arm = (np.asarray(v, dtype=float) for v in (t, command, arm))
    if np.all(command == command[0]):
        raise ValueError("the command never changes")
    k = int(np.argmax(command != command[0]))
    progress, times = (arm[k:] - arm[k - 1]) / (command[k] - arm[k - 1]), t[k:]

    def crossing(level):
        i = int(np.argmax(progress >= level))
        if progress[i + 1] == progress[i]:
            return times[i]
        return times[i] + (level - progress[i]) * (times[i + 1] - times[i]) / (progress[i + 1] - progress[i])

    return 0.8 * abs(command[k] - arm[k - 1]) / (crossing(0.9) - crossing(0.1))


def up_crossings(t, a, interpolate=True):
    t, a = np.asarray(t, float), np.asarray(a, float)
    up = np.nonzero((a[:-1] < 0) & (a[1:] >= 0))[0]
    if not interpolate:
        return t[up + 1]
    return t[up] - a[up] * (t[up + 1] - t[up]) / (a[up + 1] - a[up])


def log_decrement(peaks, log=np.log):
    peaks = np.asarray(peaks, float)
    return float(np.mean(log(peaks[:-1] / peaks[1:])))


def period_skipping_zero_readings(t, a):
    """Upward crossings read literally as "negative to positive": a[i] < 0 < a[i+1]."""
    return period_by(t, a, "a[i] < 0 < a[i+1]")


def period_from_zero_readings_on(t, a):
    """The other reading of "negative to positive": a[i] <= 0 < a[i+1]."""
    return period_by(t, a, "a[i] <= 0 < a[i+1]")


def period_failing_on_fewer_crossings(t, a):
    """Skips the 0.0 readings (a[i] < 0 < a[i+1]) and raises where that leaves fewer than two crossings."""
    t, a = np.asarray(t, float), np.asarray(a, float)
    up = np.nonzero((a[:-1] < 0) & (a[1:] > 0))[0]
    crossings = t[up] - a[up] * (t[up + 1] - t[up]) / (a[up + 1] - a[up])
    if len(crossings) < 2:
        raise ValueError(f"only {len(crossings)} crossing")
    return (crossings[-1] - crossings[0]) / (len(crossings) - 1)


def period_counting_both_directions(t, a):
    crossings = np.sort(np.concatenate([up_crossings(t, a), up_crossings(t, -np.asarray(a))]))
    return float(np.mean(np.diff(crossings))) if len(crossings) > 1 else math.nan


def period_over_crossings(t, a):
    """The span from the first crossing to the last over the number of crossings (not of periods)."""
    crossings = up_crossings(t, a)
    return float((crossings[-1] - crossings[0]) / len(crossings)) if len(crossings) > 1 else math.nan


def period_returning_zero(t, a):
    """Right, but 0.0 rather than nan with fewer than two crossings."""
    crossings = up_crossings(t, a)
    return float(np.mean(np.diff(crossings))) if len(crossings) > 1 else 0.0


def damping_with_log10(peaks):
    delta = log_decrement(peaks, np.log10)
    return delta / math.sqrt(4 * math.pi**2 + delta**2)


CORRECT = {
    "03.natural_frequency": lambda m, com, j: math.sqrt(m * 9.81 * com / j),
    "03.period_from_crossings": lambda t, a: period_by(t, a),
    "03.damping_ratio": lambda p: log_decrement(p) / math.sqrt(4 * math.pi**2 + log_decrement(p) ** 2),
    "03.slew_rate": lambda t, command, arm: slew_rate(t, command, arm),
}

MISTAKES = [
    ("03.natural_frequency", lambda m, com, j: m * 9.81 * com / j, "square root"),
    ("03.natural_frequency", lambda m, com, j: math.sqrt(m * 9.81 * com / j) / (2 * math.pi), "Hz"),
    ("03.natural_frequency", lambda m, com, j: math.sqrt(9.81 / com), "point mass"),
    ("03.period_from_crossings", lambda t, a: period_counting_both_directions(t, a), "both directions",
     {"one_crossing_per_period", "a_twin_swing"}),
    ("03.natural_frequency", lambda m, com, j: math.sqrt(j / (m * 9.81 * com)), "upside down",
     {"compound_pendulum", "the_rigs_own_pendulum"}),
    ("03.period_from_crossings", lambda t, a: period_by(t, a, interpolate=False), "without interpolation",
     {"interpolated_crossings"}),
    ("03.period_from_crossings", period_over_crossings, "divide by crossings - 1",
     {"one_crossing_per_period", "a_twin_swing"}),
    ("03.period_from_crossings", period_returning_zero, "return nan", {"fewer_than_two_crossings"}),
    ("03.slew_rate", lambda t, c, a: slew_rate(t, c, a) if np.any(np.asarray(c) != c[0]) else 0.0,
     "raise ValueError", {"a_command_that_never_changes"}),
    ("03.period_from_crossings", period_skipping_zero_readings, "yours skipped them",
     {"readings_of_exactly_zero", "a_twin_swing"}),
    ("03.period_from_crossings", period_from_zero_readings_on, "at or below 0 to one above 0",
     {"readings_of_exactly_zero", "a_twin_swing"}),
    ("03.period_from_crossings", period_failing_on_fewer_crossings, "the 0.0 readings are what it gets wrong",
     {"readings_of_exactly_zero", "a_twin_swing"}),
    ("03.damping_ratio", lambda p: log_decrement(p), "decrement itself"),
    ("03.damping_ratio", lambda p: log_decrement(p) / (2 * math.pi), "light damping"),
    ("03.damping_ratio", lambda p: damping_with_log10(p), "log10"),
    ("03.damping_ratio", lambda p: -CORRECT["03.damping_ratio"](p), "upside down", {"from_peak_amplitudes"}),
    ("03.slew_rate", lambda t, c, a: -slew_rate(t, c, a) if c[-1] < c[0] else slew_rate(t, c, a), "positive"),
    ("03.slew_rate", lambda t, c, a: slew_rate(t, c, a) / 0.8, "80 %"),
    ("03.slew_rate", lambda t, c, a: slew_rate(t, c, a, interpolate=False), "without interpolation",
     {"coarse_samples", "random_ramps"}),
    ("03.slew_rate", slew_interpolating_the_wrong_pair, "two samples around it"),
    ("03.slew_rate", lambda t, c, a: slew_rate(t, c, a, from_zero=True), "not from 0",
     {"a_ramp_after_a_lag", "random_ramps"}),
]
