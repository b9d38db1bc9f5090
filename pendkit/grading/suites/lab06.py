"""Lab 06, latency and the sim-to-real gap: public tests."""

from __future__ import annotations

import math

import numpy as np

from pendkit.grading.core import Diagnosis, Failed, as_number, expect, is_real, is_sequence_of, shown, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

jitter = task("06.period_error_p99_ms", function="period_error_p99_ms", title="Step-period jitter", hidden_points=1)
fit = task("06.fit_latency", function="fit_latency", title="A latency distribution from samples", hidden_points=1)
predict = task("06.predict_angle", function="predict_angle",
               title="Predicting the angle past the delay", hidden_points=1)


@jitter.test(points=2, hint="Periods are the differences of successive step times; compare each with the "
                            "nominal period, in milliseconds, and take the 99th percentile of the absolute error.")
def percentile_of_absolute_error(fn, rng):
    periods = 0.06 + np.concatenate([np.full(98, 0.0005), [-0.004, 0.006]])
    times = np.concatenate([[0.0], np.cumsum(periods)])
    expected = float(np.percentile(np.abs(periods - 0.06) * 1000, 99))
    got = as_number(fn(times, 0.06), "period_error_p99_ms(times, 0.06)")
    expect(abs(got - expected) < 1e-6, f"expected {expected:.3f} ms, got {got:.3f}" + jitter_note(periods, 0.06, got))


def jitter_note(periods: np.ndarray, nominal: float, got: float) -> str:
    """What a p99 period error `got` for these periods got wrong, when it is a known mistake."""
    expected = float(np.percentile(np.abs(periods - nominal) * 1000, 99))
    if abs(got - expected / 1000) < 1e-9:
        return Diagnosis(": that is in seconds; the lab wants milliseconds")
    if abs(got - float(np.percentile((periods - nominal) * 1000, 99))) < 1e-9:
        return Diagnosis(": take the absolute error: early steps count too")
    errors_ms = np.abs(periods - nominal) * 1000
    if abs(got - float(np.percentile(errors_ms, 0.99))) < 1e-9 and abs(got - expected) > 1e-9:
        return Diagnosis(": that is the 0.99th percentile, near the smallest error: np.percentile takes percent "
                         "(0-100), so the 99th is np.percentile(errors, 99), not 0.99")
    for method in OTHER_PERCENTILES:
        if abs(got - float(np.percentile(errors_ms, 99, method=method))) < 1e-9 and abs(got - expected) > 1e-9:
            return Diagnosis(f": that is the 99th percentile by another definition (np.percentile's method="
                             f"\"{method}\" gives it); the lab's is np.percentile(errors_ms, 99), numpy's default, "
                             "which interpolates linearly between the two nearest ranks")
    return ""


# the definitions a textbook or another library may use (nearest rank first), numpy's default "linear" aside
OTHER_PERCENTILES = ("nearest", "inverted_cdf", "lower", "higher", "midpoint", "closest_observation",
                     "averaged_inverted_cdf", "interpolated_inverted_cdf", "hazen", "weibull", "median_unbiased",
                     "normal_unbiased")


def _fit_result(got):
    if not is_sequence_of(got, 3):
        raise Failed(f"fit_latency should return (floor_ms, median_ms, spread), got {shown(got)}")
    return tuple(float(x) for x in got)


@fit.test(points=2, hint="floor = the smallest sample; median = the median of (sample - floor); spread = the "
                         "standard deviation of log(sample - floor) over the samples above the floor.")
def recovers_a_shifted_lognormal(fn, rng):
    floor, median, spread = 2.0, 6.0, 0.6
    samples = floor + median * np.exp(spread * rng.standard_normal(4000))
    samples = np.append(samples, floor)  # the fastest message sits on the floor
    got_floor, got_median, got_spread = _fit_result(fn(samples))
    expect(abs(got_floor - floor) < 0.05, f"floor should be about {floor} ms, got {got_floor:.3f}")
    expect(abs(got_median - median) < 0.3, f"median above the floor should be about {median} ms, got "
           f"{got_median:.3f}" + median_note(samples, got_median))
    expect(abs(got_spread - spread) < 0.05, f"spread should be about {spread}, got {got_spread:.3f}"
           + spread_note(samples, got_spread))


def median_note(samples, got: float) -> str:
    """Words for a median taken of the samples rather than of (sample - floor), or nothing."""
    if abs(got - float(np.median(np.asarray(samples, dtype=float)))) < 1e-6:
        return Diagnosis(": that is the samples' own median; subtract the floor first: the median of (sample - floor)")
    return ""


def spread_note(samples, got: float) -> str:
    """Words for a spread taken of log(sample) rather than of log(sample - floor), or without the log at all (a
    relative spread, std / median or std / mean, or a plain std), or nothing."""
    samples = np.asarray(samples, dtype=float)
    if abs(got - float(np.std(np.log(samples[samples > 0])))) < 1e-6:
        return Diagnosis(": that is the spread of log(sample); subtract the floor first: log(sample - floor)")
    if any(abs(got - spread) < 1e-6 * max(1.0, abs(spread)) for spread in spreads_without_the_log(samples)):
        return Diagnosis(": that is a spread without the log (the standard deviation of the samples or of "
                         "sample - floor, perhaps over their median or mean); the lognormal's spread is the standard "
                         "deviation of log(sample - floor): take the log first")
    return ""


def spreads_without_the_log(samples) -> list[float]:
    """The spreads a fit that leaves out the log gives: std of the samples or of (sample - floor), alone or over
    their median or mean, with ddof 0 or 1."""
    samples = np.asarray(samples, dtype=float)
    spreads = []
    for values in (samples, samples - samples.min()):
        for ddof in (0, 1):
            std = float(np.std(values, ddof=ddof))
            spreads += [std] + [std / centre for centre in (float(np.median(values)), float(np.mean(values))) if centre]
    return spreads


@fit.test(points=1, hint="If no sample lies above the floor (all of them equal), return a spread of 0.0.")
def all_samples_equal(fn, rng):
    samples = [5.0] * 50  # a latency that never varies
    got_floor, _, got_spread = _fit_result(fn(samples))
    expect(got_floor == 5.0, f"fit_latency([5.0] * 50): the floor should be 5.0 ms, the smallest sample, got "
           f"{got_floor:.3f}")
    note = ""
    if math.isnan(got_spread):
        note = Diagnosis(": no sample lies above the floor, so the spread has nothing to measure (a standard "
                         "deviation of no values, or 0 / 0, is nan); return 0.0 then, as the lab says")
    expect(got_spread == 0.0, f"fit_latency([5.0] * 50): the spread should be 0.0 (all samples equal: a latency "
           f"that never varies), got {got_spread}" + note)


@predict.test(points=2, hint="Near upright theta'' = w0^2 theta, so "
                             "theta(t + d) = theta + theta' d + w0^2 theta d^2 / 2.")
def second_order_prediction(fn, rng):
    for theta, rate, delay, w0 in [(0.1, 0.0, 0.04, 5.3), (0.0, 1.0, 0.05, 5.3), (-0.05, 0.3, 0.03, 5.0)]:
        expected = theta + rate * delay + 0.5 * w0**2 * theta * delay**2
        got = as_number(fn(theta, rate, delay, w0), "predict_angle(...)")
        message = f"predict_angle({theta}, {rate}, {delay}, {w0}) should be {expected:.5f}, got {got:.5f}"
        expect(abs(got - expected) < 1e-9, message + prediction_note(theta, rate, delay, w0, got))
    expect(math.isfinite(as_number(fn(0.0, 0.0, 0.0, 5.3), "predict_angle(0, 0, 0, 5.3)")), "zero delay must work")


def prediction_note(theta: float, rate: float, delay: float, w0: float, got) -> str:
    """Words for the gravity term's mistakes (left out, or its sign flipped) and a flipped velocity term."""
    if not is_real(got):
        return ""
    if theta and w0 != 1 and abs(got - (theta + rate * delay + 0.5 * w0 * theta * delay**2)) < 1e-12:
        return Diagnosis(": w0 is not squared: near upright theta'' = w0^2 theta, so the term is "
                         "w0^2 theta d^2 / 2")
    if theta and abs(got - (theta + rate * delay)) < 1e-12:
        return Diagnosis(": you left out gravity, which pushes the pendulum away from upright during the delay")
    if theta and abs(got - (theta + rate * delay - 0.5 * w0**2 * theta * delay**2)) < 1e-12:
        return Diagnosis(": upright, gravity pushes away from the top: + w0^2 theta, not minus")
    if abs(got - (theta - rate * delay + 0.5 * w0**2 * theta * delay**2)) < 1e-12 and rate:
        return Diagnosis(": the velocity term's sign is flipped: the angle moves on by + theta' d")
    return ""


prelab_task("06", ("round_trip_ms", "growth_during_delay",))

written("06.reflection", "Reflection", points=3)
