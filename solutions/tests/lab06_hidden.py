"""Hidden tests for lab 06 (instructor material: never copied into labs/)."""

import numpy as np

from pendkit.grading import expect, task
from pendkit.grading.core import as_number, is_real, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab06 import jitter_note, median_note, prediction_note, spread_note

jitter = task("06.period_error_p99_ms", function="period_error_p99_ms", title="Step-period jitter")
fit = task("06.fit_latency", function="fit_latency", title="A latency distribution from samples")
predict = task("06.predict_angle", function="predict_angle", title="Predicting the angle past the delay")


@jitter.test(points=1, hidden=True, hint="A 35 ms nominal period: 300 steps of random jitter, from t = 5 s.")
def other_periods(fn, rng):
    periods = 0.035 + rng.normal(0, 0.001, 300)
    times = np.concatenate([[5.0], 5.0 + np.cumsum(periods)])
    expected = float(np.percentile(np.abs(periods - 0.035) * 1000, 99))
    got = as_number(fn(times, 0.035), "period_error_p99_ms(times, 0.035)")
    expect(abs(got - expected) < 1e-6, f"for a 35 ms period with random jitter: expected {expected:.3f} ms, "
                                       f"got {got:.3f}" + jitter_note(np.diff(times), 0.035, got))


@fit.test(points=1, hidden=True, hint="A list (not an array) of a narrow distribution on a high floor.")
def narrow_distribution_from_a_list(fn, rng):
    # a floor as high as the median: log(sample) without it gives a spread far from 0.2 (about 0.12)
    samples = list(3.0 + 3.0 * np.exp(0.2 * rng.standard_normal(2000))) + [3.0]
    floor, median, spread = (float(x) for x in fn(samples))
    expect(abs(floor - 3.0) < 1e-9 and abs(median - 3.0) < 0.1 and abs(spread - 0.2) < 0.02,
           f"expected about (3.0, 3.0, 0.2), got ({floor:.3f}, {median:.3f}, {spread:.3f})"
           + (median_note(samples, median) or spread_note(samples, spread)))


@predict.test(points=1, hidden=True, hint="20 random states of either sign, delays up to 0.1 s.")
def random_states(fn, rng):
    for theta, rate, delay in rng.uniform([-0.2, -2, 0], [0.2, 2, 0.1], (20, 3)):
        expected = theta + rate * delay + 0.5 * 5.3**2 * theta * delay**2
        got = fn(theta, rate, delay, 5.3)
        expect(is_real(got) and abs(got - expected) < 1e-9,
               f"predict_angle({theta:.3f}, {rate:.3f}, {delay:.3f}, 5.3) should be {expected:.5f}, got {shown(got)}"
               + prediction_note(theta, rate, delay, 5.3, got))


prelab_answers("06", {"round_trip_ms": 40.0, "growth_during_delay": 1.419068}, how={
    "round_trip_ms": "there and back: 20 ms + 20 ms = 40 ms",
    "growth_during_delay": "a tilt grows as e^(5 t); for t = 70 ms = 0.07 s: e^(5 × 0.07) = e^0.35 ≈ 1.42"})


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def fit_latency(samples, subtract_floor=True, spread_above_floor=True, log=True, guard=True):
    samples = np.asarray(samples, float)
    floor = samples.min()
    above = samples - floor if subtract_floor else samples
    logged = samples - floor if spread_above_floor else samples
    if not log:  # a relative spread, std / median, with no log taken
        return floor, float(np.median(above)), float(np.std(samples - floor) / np.median(samples - floor))
    if guard and not (logged > 0).any():
        return floor, float(np.median(above)), 0.0
    with np.errstate(all="ignore"):
        return floor, float(np.median(above)), float(np.std(np.log(logged[logged > 0])))


def nearest_rank_p99(values):
    """The textbook's nearest-rank 99th percentile: the smallest sample with 99% of them at or below it."""
    ordered = np.sort(np.asarray(values, dtype=float))
    return float(ordered[int(np.ceil(0.99 * len(ordered))) - 1])


CORRECT = {
    "06.period_error_p99_ms": lambda t, nominal: float(np.percentile(np.abs(np.diff(t) - nominal) * 1000, 99)),
    "06.fit_latency": lambda samples: fit_latency(samples),
    "06.predict_angle": lambda theta, rate, d, w0: theta + rate * d + 0.5 * w0**2 * theta * d**2,
}

MISTAKES = [
    ("06.period_error_p99_ms", lambda t, n: float(np.percentile(np.abs(np.diff(t) - n), 99)), "in seconds",
     {"percentile_of_absolute_error", "other_periods"}),
    ("06.period_error_p99_ms", lambda t, n: float(np.percentile((np.diff(t) - n) * 1000, 99)), "absolute error"),
    ("06.fit_latency", lambda samples: fit_latency(samples, subtract_floor=False), "subtract the floor"),
    ("06.fit_latency", lambda samples: fit_latency(samples, spread_above_floor=False), "spread of log(sample)",
     {"recovers_a_shifted_lognormal", "narrow_distribution_from_a_list"}),
    ("06.period_error_p99_ms", lambda t, n: float(np.percentile(np.abs(np.diff(t) - n) * 1000, 0.99)),
     "takes percent", {"percentile_of_absolute_error", "other_periods"}),
    ("06.period_error_p99_ms", lambda t, n: nearest_rank_p99(np.abs(np.diff(t) - n) * 1000), "another definition",
     {"percentile_of_absolute_error", "other_periods"}),
    ("06.predict_angle", lambda theta, rate, d, w0: theta + rate * d + 0.5 * w0 * theta * d**2, "not squared",
     {"second_order_prediction", "random_states"}),
    ("06.predict_angle", lambda theta, rate, d, w0: theta + rate * d, "left out gravity"),
    ("06.predict_angle", lambda theta, rate, d, w0: theta + rate * d - 0.5 * w0**2 * theta * d**2, "not minus"),
    ("06.predict_angle", lambda theta, rate, d, w0: theta - rate * d + 0.5 * w0**2 * theta * d**2, "velocity term"),
    ("06.fit_latency", lambda samples: fit_latency(samples, log=False), "take the log first",
     {"recovers_a_shifted_lognormal"}),
    ("06.fit_latency", lambda samples: fit_latency(samples, guard=False), "return 0.0 then", {"all_samples_equal"}),
]
