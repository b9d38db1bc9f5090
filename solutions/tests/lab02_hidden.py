"""Hidden tests for lab 02 (instructor material: never copied into labs/)."""

import math

import numpy as np

from pendkit import encoder
from pendkit.grading import expect, task
from pendkit.grading.core import is_sequence_of, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab02 import limits_note, low_pass_note, mean_note, velocity_note

velocity = task("02.velocity_rev_s", function="velocity_rev_s", title="Wrap-aware velocity in rev/s")
mean = task("02.firmware_mean", function="firmware_mean", title="The firmware's mean of the last N")


@velocity.test(points=2, hidden=True, hint="Check against the shared firmware test vectors.")
def matches_the_firmware_on_a_twin_log(fn, rng):
    from pendkit.sim.lab_readings import free_swing_readings

    readings = free_swing_readings(period_ms=25.0, duration_s=2.0, offset_counts=int(rng.integers(0, 1024)))
    expected = encoder.finite_difference_rev_s(readings.raw_counts, readings.times_ms)
    got = np.asarray(fn(readings.raw_counts.tolist(), readings.times_ms.tolist()), dtype=float)
    expect(got.shape == expected.shape, f"velocities of a 2 s spin on the twin: expected {expected.shape[0]} values, "
                                        f"got shape {got.shape}")
    expect(np.allclose(got, expected, atol=1e-9), "velocities of a 2 s spin on the twin differ from the firmware's"
           + velocity_note(got, expected, readings.raw_counts, readings.times_ms))


@mean.test(points=1, hidden=True, hint="Feed your mean the raw velocities: it must equal the firmware's report.")
def composes_to_the_firmware_estimate(fn, rng):
    positions = rng.integers(0, 1024, 30)
    times = np.arange(30) * 25.0
    reference, _ = encoder.firmware_velocity(positions, times, 4)
    raw = np.concatenate([[0.0], encoder.finite_difference_rev_s(positions, times)])
    got = np.asarray(fn(raw.tolist(), 4), dtype=float)
    expect(got.shape == reference.shape and np.allclose(got, reference, atol=1e-9),
           "firmware_mean of raw velocities differs from the firmware" + mean_note(raw, 4, got, reference))


smooth = task("02.low_pass", function="low_pass", title="A first-order low-pass")
limits = task("02.period_limits", function="period_limits", title="What a reading period can resolve")


@smooth.test(points=1, hidden=True, hint="Random signals (none starting at zero), alpha from 0.05 to 1.")
def random_signals(fn, rng):
    for alpha in rng.uniform(0.05, 1.0, 4):
        values = rng.normal(size=int(rng.integers(3, 40)))
        expected = encoder.low_pass(values, float(alpha))
        got = np.asarray(fn(values.tolist(), float(alpha)), dtype=float)
        if got.shape != expected.shape:
            expect(False, f"low_pass of {len(values)} values should return {len(values)}, got shape {got.shape}")
        expect(np.allclose(got, expected), f"low_pass(x, {alpha:.3f}) with x starting "
               f"{np.round(values[:3], 3).tolist()} should start {np.round(expected[:3], 3).tolist()}, "
               f"got {np.round(got[:3], 3).tolist()}"
               + low_pass_note(values, float(alpha), got))


@limits.test(points=1, hidden=True, hint="Both limits scale with 1 / period.")
def random_periods(fn, rng):
    for period_ms in rng.uniform(1.0, 500.0, 5):
        got = fn(float(period_ms))
        period_s = period_ms / 1000
        want = (1 / 1024 / period_s, 0.5 / period_s)
        expect(is_sequence_of(got, 2), f"period_limits({period_ms:.2f}) should return a pair (quantisation step, "
               f"aliasing limit), got {shown(got)}")
        step, limit = float(got[0]), float(got[1])
        ok = abs(step - want[0]) < 1e-9 and abs(limit - want[1]) < 1e-9
        expect(ok, f"period_limits({period_ms:.2f}) should be ({want[0]:.4g}, {want[1]:.4g}) rev/s, got "
                   f"({step:.4g}, {limit:.4g})" + limits_note(float(period_ms), step, limit))


prelab_answers("02", {"slowest_rev_s": 0.097656, "fastest_rev_s": 20.0}, how={
    "slowest_rev_s": "one count (1/1024 of a turn) in 10 ms = 0.010 s: (1/1024) / 0.010 ≈ 0.0977 rev/s",
    "fastest_rev_s": "beyond half a turn between readings the shorter way is the wrong way: 0.5 turn / 0.025 s = "
                     "20 rev/s"})


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def velocity_no_wrap(p, t):
    return np.diff(np.asarray(p, float)) * 1000 / (1024 * np.diff(np.asarray(t, float)))


def velocity_rad_s(p, t):
    return encoder.finite_difference_rev_s(p, t) * 2 * math.pi


def velocity_seconds(p, t):
    return encoder.finite_difference_rev_s(p, t) / 1000


def velocity_1023(p, t):
    return encoder.finite_difference_rev_s(p, t) * 1024 / 1023


def mean_without_zero_padding(v, w):
    v = np.asarray(v, float)
    return np.array([v[max(0, k - w + 1): k + 1].mean() for k in range(len(v))])


def mean_one_step_late(v, w):
    """Pads `w` zeros, so each output is the mean of the `w` values before the current one."""
    padded = np.concatenate([np.zeros(w), np.asarray(v, float)])
    return np.convolve(padded, np.ones(w) / w, "valid")[:-1]


def velocity_old_minus_new(p, t):
    return -encoder.finite_difference_rev_s(p, t)


def mean_centred(v, w):
    return np.convolve(v, np.ones(w) / w, mode="same")


def low_pass_swapped(v, a):
    out, y = [], float(v[0])
    for x in v:
        y = a * y + (1 - a) * x
        out.append(y)
    return np.array(out)


def low_pass_from_zero(v, a):
    out, y = [], 0.0
    for x in v:
        y = y + a * (x - y)
        out.append(y)
    return np.array(out)


CORRECT = {
    "02.velocity_rev_s": lambda p, t: encoder.finite_difference_rev_s(p, t),
    "02.firmware_mean": lambda v, w: np.convolve(np.concatenate([np.zeros(w - 1), v]), np.ones(w) / w, "valid"),
    "02.low_pass": lambda v, a: encoder.low_pass(v, a),
    "02.period_limits": lambda ms: (1 / 1024 / (ms / 1000), 0.5 / (ms / 1000)),
}

MISTAKES = [
    ("02.velocity_rev_s", velocity_no_wrap, "wrap-aware"),
    ("02.velocity_rev_s", velocity_rad_s, "rad/s", {"matches_the_firmware_on_a_twin_log", "steady_rotation"}),
    ("02.velocity_rev_s", velocity_seconds, "milliseconds", {"steady_rotation", "matches_the_firmware_on_a_twin_log"}),
    ("02.velocity_rev_s", velocity_1023, "not 1023"),
    ("02.firmware_mean", mean_without_zero_padding, "full of zeros",
     {"mean_of_the_last_window", "composes_to_the_firmware_estimate"}),
    ("02.firmware_mean", mean_centred, "looks ahead"),
    ("02.firmware_mean", mean_one_step_late, "your outputs are one step late: include the current value in the window",
     {"mean_of_the_last_window", "other_window_lengths", "composes_to_the_firmware_estimate"}),
    ("02.velocity_rev_s", velocity_old_minus_new, "the sign is flipped: new minus old",
     {"steady_rotation", "across_the_seam_both_ways", "uneven_intervals", "matches_the_firmware_on_a_twin_log"}),
    ("02.low_pass", lambda v, a: encoder.low_pass(v, 1 - a) if a < 1 else np.asarray(v, float), "1 - alpha"),
    ("02.low_pass", low_pass_swapped, "1 - alpha", {"step_response", "random_signals", "alpha_one_is_identity"}),
    ("02.low_pass", low_pass_from_zero, "started from y = 0", {"step_response", "random_signals"}),
    ("02.period_limits", lambda ms: (1 / 1024 / (ms / 1000), 1 / (ms / 1000)), "half a turn",
     {"quantisation_and_aliasing", "random_periods"}),
    ("02.period_limits", lambda ms: (2 * math.pi / 1024 / (ms / 1000), 0.5 / (ms / 1000)), "rad/s"),
    ("02.period_limits", lambda ms: (1 / 1024 / ms, 1 / ms), "milliseconds: convert it to seconds; and a full turn",
     {"quantisation_and_aliasing", "random_periods"}),
    ("02.period_limits", lambda ms: (1 / 1024 / ms, 0.5 / ms), "milliseconds",
     {"quantisation_and_aliasing", "random_periods"}),
]
