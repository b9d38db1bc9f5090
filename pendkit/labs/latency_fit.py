"""Lab 06: the student's latency fit against the samples it came from, and their jitter beside numpy's, in
words."""

from __future__ import annotations

import numpy as np

from pendkit.grading.suites.lab06 import jitter_note, spreads_without_the_log


def fit_lines(fitted, samples_ms) -> list[str]:
    """Lines comparing the model `fitted` = (floor, median above it, spread) with the samples it came from:
    its median latency against theirs, then `fit_problems` (or that there are none)."""
    floor, median = float(fitted[0]), float(fitted[1])
    lines = [f"your model's median one-way latency, floor + median: {floor + median:.1f} ms (the samples': "
             f"{np.median(np.asarray(samples_ms, dtype=float)):.1f} ms)"]
    problems = fit_problems(fitted, samples_ms)
    return lines + (problems or ["  your fit matches the samples: its median, and its spread of log(sample - floor)"])


def fit_problems(fitted, samples_ms) -> list[str]:
    """A line for each part of `fitted` that is off from the samples, naming the mistake when a known one
    shows; none for a right fit."""
    samples = np.asarray(samples_ms, dtype=float)
    median, spread = float(fitted[1]), float(fitted[2])
    above = samples - samples.min()
    right_median, right_spread = float(np.median(above)), float(np.std(np.log(above[above > 0])))
    lines = []
    if abs(median - float(np.median(samples))) < 1e-6 and samples.min() > 0:
        lines.append(f"  your median ({median:.2f} ms) is the samples' own, not that of (sample - floor): the floor "
                     f"counts twice, and the lognormal, its tail too, is {median / right_median:.1f} times too long")
    elif abs(median - right_median) > 0.05 * right_median:
        lines.append(f"  your median above the floor is {median:.2f} ms; the samples' is {right_median:.2f} ms")
    positive = samples[samples > 0]
    if abs(spread - float(np.std(np.log(positive)))) < 1e-6 and abs(spread - right_spread) > 1e-6:
        lines.append(f"  your spread ({spread:.2f}) is that of log(sample), not of log(sample - floor): the samples' "
                     f"is {right_spread:.2f}, so your model's tail is too short")
    elif any(abs(spread - other) < 1e-6 * max(1.0, abs(other)) for other in spreads_without_the_log(samples)):
        lines.append(f"  your spread ({spread:.2f}) is taken without the log: the lognormal's is the standard "
                     f"deviation of log(sample - floor), here {right_spread:.2f}: take the log first")
    elif abs(spread - right_spread) > 0.05 * right_spread:
        lines.append(f"  your spread is {spread:.2f}; the samples' (of log(sample - floor)) is {right_spread:.2f}")
    return lines


def jitter_lines(got, step_times_s, nominal_s: float) -> list[str]:
    """The student's p99 step-period error beside numpy's default percentile on the same steps: a jitter varies
    from run to run, so only the two side by side show a slip; when they part, its cause if a known one."""
    errors_ms = np.abs(np.diff(np.asarray(step_times_s, dtype=float)) - nominal_s) * 1000
    reference = float(np.percentile(errors_ms, 99))
    try:
        value = float(got)
    except (TypeError, ValueError):
        return [f"p99 step-period error here: yours is {got!r}, not a number of ms; np.percentile's default on "
                f"these steps gives {reference:.2f} ms"]
    lines = [f"p99 step-period error here: yours {value:.2f} ms; np.percentile(errors_ms, 99) on these same steps "
             f"{reference:.2f} ms"]
    if abs(value - reference) > 1e-6 * max(1.0, reference):
        note = jitter_note(np.diff(np.asarray(step_times_s, dtype=float)), nominal_s, value)
        lines.append("  they differ" + (note or ": the check above says how"))
    return lines
