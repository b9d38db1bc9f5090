"""Lab 02, velocity estimation: public tests."""

from __future__ import annotations

import math

import numpy as np

from pendkit import encoder
from pendkit.grading.core import Diagnosis, Failed, expect, is_sequence_of, shown, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

velocity = task("02.velocity_rev_s", function="velocity_rev_s", title="Wrap-aware velocity in rev/s", hidden_points=2)
mean = task("02.firmware_mean", function="firmware_mean", title="The firmware's mean of the last N", hidden_points=1)
smooth = task("02.low_pass", function="low_pass", title="First-order low-pass", hidden_points=1)
limits = task("02.period_limits", function="period_limits",
              title="Quantisation step and aliasing limit", hidden_points=1)


def _as_array(got, name: str, length: int) -> np.ndarray:
    try:
        array = np.asarray(got, dtype=float)
    except (TypeError, ValueError) as error:
        raise Failed(f"{name} should return an array of numbers, got {type(got).__name__}") from error
    expect(array.shape == (length,), f"{name} should return {length} values, got shape {array.shape}")
    return array


def velocity_note(got: np.ndarray, expected: np.ndarray, positions, times) -> str:
    """What a velocity that differs from `expected` got wrong, when it is a known mistake."""
    if np.abs(expected).max(initial=0) > 1e-9 and np.allclose(got, -expected, atol=1e-9):
        return Diagnosis(": the sign is flipped: new minus old (a count that grows is a positive speed)")
    if np.allclose(got, expected * 2 * math.pi, atol=1e-6):
        return Diagnosis(": these are rad/s; the firmware reports revolutions per second (divide by 2 pi)")
    if np.allclose(got, expected / 1000, atol=1e-9) or np.allclose(got, expected * 1000, atol=1e-6):
        return Diagnosis(": off by a factor of 1000; times are in milliseconds")
    plain = np.diff(np.asarray(positions, dtype=float)) * 1000 / (1024 * np.diff(np.asarray(times, float)))
    if np.allclose(got, plain, atol=1e-6):
        return Diagnosis(": huge jumps at the 1023 -> 0 seam; use a wrap-aware difference (lab 01)")
    if np.allclose(got, expected * 1024 / 1023, atol=1e-6):
        return Diagnosis(": a turn has 1024 positions, not 1023")
    return ""


@velocity.test(points=2, hint="(new - old) counts / 1024 = revolutions; divide by the interval in seconds.")
def steady_rotation(fn, rng):
    positions, times = [100, 110, 120, 130], [0.0, 25.0, 50.0, 75.0]
    expected = np.full(3, 10 / 1024 / 0.025)
    got = _as_array(fn(positions, times), "velocity_rev_s", 3)
    expect(np.allclose(got, expected, atol=1e-9), f"velocity_rev_s({positions}, {times}) should be about "
           f"{expected[0]:.4f} rev/s each, got {np.round(got, 4).tolist()}"
           + velocity_note(got, expected, positions, times))


def scaled(got: np.ndarray, expected: np.ndarray) -> float | None:
    """The factor k > 0, other than 1, with got = k * expected throughout (a units slip, which
    steady_rotation scores), or None."""
    nonzero = np.abs(expected) > 1e-12
    if got.shape != expected.shape or not nonzero.any():
        return None
    k = float(got[nonzero][0] / expected[nonzero][0])
    if k <= 0 or abs(k - 1) < 1e-9 or not np.allclose(got, k * expected, rtol=1e-9, atol=1e-12):
        return None
    return k


def units_aside(k: float, what: str) -> str:
    return (f"{what} is right; your values are {k:.6g} times the right ones throughout, a units or scale slip that "
            "steady_rotation scores")


@velocity.test(points=3, hint="Use the wrap-aware difference from lab 01 for every pair of readings.")
def across_the_seam_both_ways(fn, rng):
    # the wrap is this test's to score: values that are all the same multiple of the right ones pass here
    factors = set()
    for positions in ([1000, 1020, 16, 36], [30, 5, 1004, 980]):
        times = [0.0, 25.0, 50.0, 75.0]
        expected = encoder.finite_difference_rev_s(positions, times)
        got = _as_array(fn(positions, times), "velocity_rev_s", 3)
        k = scaled(got, expected)
        if k is not None:
            factors.add(round(k, 9))
            continue
        expect(np.allclose(got, expected, atol=1e-9), f"velocity_rev_s({positions}, ...) should be "
               f"{np.round(expected, 4).tolist()}, got {np.round(got, 4).tolist()}"
               + velocity_note(got, expected, positions, times))
    if factors:
        return units_aside(max(factors), "across the seam, the wrap")


@velocity.test(points=1, hint="Intervals need not be equal: use each pair's own time difference.")
def uneven_intervals(fn, rng):
    times = np.cumsum(rng.integers(20, 31, 8)).astype(float)
    positions = 400 + np.cumsum(rng.integers(-40, 41, 8))  # far from the seam: this test is about timing only
    expected = encoder.finite_difference_rev_s(positions, times)
    got = _as_array(fn(positions.tolist(), times.tolist()), "velocity_rev_s", 7)
    k = scaled(got, expected)  # the units are steady_rotation's to score: this test scores each pair's own interval
    if k is not None:
        return units_aside(k, "each pair's own interval")
    expect(np.allclose(got, expected, atol=1e-9), f"with uneven intervals {np.diff(times).tolist()} ms the "
           f"velocities should be {np.round(expected, 3).tolist()}, got {np.round(got, 3).tolist()}"
           + velocity_note(got, expected, positions.tolist(), times.tolist()))


@mean.test(points=2, hint="Each output is the mean of the last `window` inputs, counting zeros before the start.")
def mean_of_the_last_window(fn, rng):
    values = [4.0, 8.0, 0.0, 4.0, 12.0, 4.0]
    expected = np.array([1.0, 3.0, 3.0, 4.0, 6.0, 5.0])
    got = _as_array(fn(values, 4), "firmware_mean", 6)
    message = f"firmware_mean({values}, 4) should be {expected.tolist()}, got {np.round(got, 4).tolist()}"
    expect(np.allclose(got, expected), message + mean_note(values, 4, got, expected))
    short, expected = [2.0, 4.0, 6.0], np.array([0.4, 1.2, 2.4])  # a window longer than the data: zeros throughout
    got = _as_array(fn(short, 5), "firmware_mean", 3)
    expect(np.allclose(got, expected), f"firmware_mean({short}, 5) should be {expected.tolist()} (a window longer "
           f"than the data: every output still divides by 5), got {np.round(got, 4).tolist()}"
           + mean_note(short, 5, got, expected))


LATE = ": your outputs are one step late: include the current value in the window"


def one_step_late(got: np.ndarray, expected: np.ndarray) -> bool:
    """Each output is the one before it should have been: the window ends a value early (the current one left
    out)."""
    return (got.shape == expected.shape and len(got) > 1 and not np.allclose(got, expected)
            and np.allclose(got[1:], expected[:-1]))


def mean_note(values, window: int, got: np.ndarray, expected: np.ndarray) -> str:
    """Words for the common mistakes of a mean of the last `window` values, or nothing."""
    if got.shape != expected.shape:
        return ""
    if one_step_late(got, expected):
        return Diagnosis(LATE)
    if window < 2:
        return ""
    if np.allclose(got[window - 1:], expected[window - 1:]) and not np.allclose(got[:window - 1],
                                                                               expected[:window - 1]):
        return Diagnosis(f": the firmware's buffer starts full of zeros, so early outputs divide by {window} too "
                         "(only the first window - 1 values differ)")
    if len(values) >= window and np.allclose(got, np.convolve(values, np.ones(window) / window, mode="same")):
        return Diagnosis(": np.convolve(mode='same') centres the window and looks ahead; use only past values")
    return ""


@mean.test(points=1, hint="Any window length must work: from the window-th output on, each is the mean of the last "
                          "`window` values.")
def other_window_lengths(fn, rng):
    # the window's length is this test's to score, once the buffer is full: the zeros it starts with are
    # mean_of_the_last_window's
    values = rng.normal(size=12)
    for window in (1, 3):
        padded = np.concatenate([np.zeros(window - 1), values])
        expected = np.convolve(padded, np.ones(window) / window, mode="valid")
        got = _as_array(fn(values.tolist(), window), "firmware_mean", 12)
        full = slice(window - 1, None)
        expect(np.allclose(got[full], expected[full]), f"firmware_mean(..., {window}): from output {window} on "
               f"expected {np.round(expected[full][:4], 3).tolist()}..., got {np.round(got[full][:4], 3).tolist()}..."
               + mean_note(values, window, got, expected))


def low_pass_note(values, alpha: float, got: np.ndarray) -> str:
    """The cause of a low-pass output that differs from the right one, named from its values, or ""."""
    values = np.asarray(values, dtype=float)
    if got.shape != values.shape or not len(values):
        return ""
    from_zero = np.concatenate([[0.0], values])
    if alpha < 1 and np.allclose(got, encoder.low_pass(values, 1 - alpha)):
        return Diagnosis(": alpha is the weight of the *new* value; you used 1 - alpha")
    if alpha == 1 and np.allclose(got, values[0]) and not np.allclose(values, values[0]):
        return Diagnosis(": with alpha = 1 the output never left x_0: alpha weights the new value and 1 - alpha "
                         "the old output; you swapped them")
    if np.allclose(got, encoder.low_pass(from_zero, alpha)[1:]):
        return Diagnosis(": it started from y = 0; the filter starts at the first sample, y_0 = x_0")
    if alpha < 1 and np.allclose(got, encoder.low_pass(from_zero, 1 - alpha)[1:]):
        return Diagnosis(": it started from y = 0 (start at y_0 = x_0) and used 1 - alpha as the new value's weight")
    return ""


@smooth.test(points=2, hint="y_k = y_(k-1) + alpha * (x_k - y_(k-1)), starting from y_0 = x_0.")
def step_response(fn, rng):
    for values in ([0.0, 1.0, 1.0, 1.0, 1.0], [2.0, 3.0, 3.0, 3.0, 3.0]):  # the second starts off zero
        expected = encoder.low_pass(values, 0.25)
        got = _as_array(fn(values, 0.25), "low_pass", 5)
        expect(np.allclose(got, expected), f"low_pass({values}, 0.25) should be {np.round(expected, 4).tolist()}, "
               f"got {np.round(got, 4).tolist()}" + low_pass_note(values, 0.25, got))


@smooth.test(points=1, hint="alpha = 1 must pass the signal through unchanged.")
def alpha_one_is_identity(fn, rng):
    values = rng.normal(size=10)
    got = _as_array(fn(values.tolist(), 1.0), "low_pass", 10)
    expect(np.allclose(got, values), f"low_pass(x, 1.0) should return x unchanged: expected "
           f"{np.round(values[:3], 3).tolist()}..., got {np.round(got[:3], 3).tolist()}..."
           + low_pass_note(values, 1.0, got))


@limits.test(points=2, hint="One count per period is the smallest non-zero speed the estimate can show; "
                            "half a turn per period is the fastest the shorter-way rule can tell apart.")
def quantisation_and_aliasing(fn, rng):
    for period_ms in (5.0, 25.0, 100.0):
        got = fn(period_ms)
        expect(is_sequence_of(got, 2), f"period_limits({period_ms}) should return a pair "
               f"(quantisation step, aliasing limit), got {shown(got)}")
        step, limit = float(got[0]), float(got[1])
        want_step, want_limit = 1 / 1024 / (period_ms / 1000), 0.5 / (period_ms / 1000)
        message = (f"period_limits({period_ms}) should be ({want_step:.4f}, {want_limit:.2f}) rev/s, "
                   f"got ({step:.4f}, {limit:.2f})")
        expect(abs(step - want_step) < 1e-9 and abs(limit - want_limit) < 1e-9,
               message + limits_note(period_ms, step, limit))


def limits_note(period_ms: float, step: float, limit: float) -> str:
    """The causes of a wrong (quantisation step, aliasing limit) for `period_ms`, named from their values: the
    period taken in milliseconds, a full turn for the limit, rad/s for the step (one slip or several)."""
    want_step, want_limit = 1 / 1024 / (period_ms / 1000), 0.5 / (period_ms / 1000)

    def near(got, want):
        return abs(got - want) < 1e-9 * abs(want)

    causes = []
    step_in_ms = near(step, want_step / 1000) or near(step, 2 * math.pi * want_step / 1000)
    if step_in_ms and (near(limit, want_limit / 1000) or near(limit, 2 * want_limit / 1000)):
        causes.append("off by a factor of 1000; the period arrives in milliseconds: convert it to seconds")
    if near(limit, 2 * want_limit) or near(limit, 2 * want_limit / 1000):
        causes.append("a full turn per period would look like no motion at all; the limit is half a turn")
    if near(step, 2 * math.pi * want_step) or near(step, 2 * math.pi * want_step / 1000):
        causes.append("rev/s please, not rad/s")
    return Diagnosis(": " + "; and ".join(causes)) if causes else ""


prelab_task("02", ("slowest_rev_s", "fastest_rev_s",))

written("02.reflection", "Reflection", points=3)
