"""Hidden tests for lab 02 (instructor material: never copied into labs/)."""

import numpy as np

from pendkit import encoder
from pendkit.grading import expect, task
from pendkit.grading.prelab import prelab_answers

velocity = task("02.velocity_rev_s", function="velocity_rev_s", title="Wrap-aware velocity in rev/s")
mean = task("02.firmware_mean", function="firmware_mean", title="The firmware's mean of the last N")


@velocity.test(points=2, hidden=True, hint="Check against the shared firmware test vectors.")
def matches_the_firmware_on_a_twin_log(fn, rng):
    from pendkit.sim.lab_readings import free_swing_readings

    readings = free_swing_readings(period_ms=25.0, duration_s=2.0, offset_counts=int(rng.integers(0, 1024)))
    expected = encoder.finite_difference_rev_s(readings.raw_counts, readings.times_ms)
    got = np.asarray(fn(readings.raw_counts.tolist(), readings.times_ms.tolist()), dtype=float)
    expect(got.shape == expected.shape and np.allclose(got, expected, atol=1e-9),
           "velocities of a 2 s spin on the twin differ from the firmware's")


@mean.test(points=1, hidden=True, hint="Feed your mean the raw velocities: it must equal the firmware's report.")
def composes_to_the_firmware_estimate(fn, rng):
    positions = rng.integers(0, 1024, 30)
    times = np.arange(30) * 25.0
    reference, _ = encoder.firmware_velocity(positions, times, 4)
    raw = np.concatenate([[0.0], encoder.finite_difference_rev_s(positions, times)])
    got = np.asarray(fn(raw.tolist(), 4), dtype=float)
    expect(np.allclose(got, reference, atol=1e-9), "firmware_mean of raw velocities differs from the firmware")


smooth = task("02.low_pass", function="low_pass", title="A first-order low-pass")
limits = task("02.period_limits", function="period_limits", title="What a reading period can resolve")


@smooth.test(points=1, hidden=True, hint="Any alpha in (0, 1] and any input length.")
def random_signals(fn, rng):
    for alpha in rng.uniform(0.05, 1.0, 4):
        values = rng.normal(size=int(rng.integers(3, 40)))
        expected = encoder.low_pass(values, float(alpha))
        got = np.asarray(fn(values.tolist(), float(alpha)), dtype=float)
        expect(got.shape == expected.shape and np.allclose(got, expected),
               f"low_pass(..., {alpha:.3f}) differs from y_k = y_(k-1) + alpha (x_k - y_(k-1))")


@limits.test(points=1, hidden=True, hint="Both limits scale with 1 / period.")
def random_periods(fn, rng):
    for period_ms in rng.uniform(1.0, 500.0, 5):
        got = fn(float(period_ms))
        period_s = period_ms / 1000
        expect(len(got) == 2 and abs(float(got[0]) - 1 / 1024 / period_s) < 1e-9
               and abs(float(got[1]) - 0.5 / period_s) < 1e-9, f"period_limits({period_ms:.2f}) is wrong")


prelab_answers("02", {"slowest_rev_s": 0.097656, "fastest_rev_s": 20.0})
