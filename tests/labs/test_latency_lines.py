"""Lab 06: the lines under the jitter and the fit name a slip on the student's own run (a jitter varies from run
to run, so the student's value is printed beside numpy's on the same steps); the labs' bars save their count."""

import numpy as np

from pendkit.labs.latency_fit import fit_problems, jitter_lines

NOMINAL_S = 0.06
PERIODS_S = NOMINAL_S + np.random.default_rng(0).normal(0, 0.0008, 149)  # a run of 150 steps
TIMES_S = np.concatenate([[0.0], np.cumsum(PERIODS_S)])
ERRORS_MS = np.abs(PERIODS_S - NOMINAL_S) * 1000


def test_a_right_jitter_is_printed_beside_numpys_and_agrees():
    lines = jitter_lines(float(np.percentile(ERRORS_MS, 99)), TIMES_S, NOMINAL_S)
    assert len(lines) == 1 and "yours" in lines[0] and "np.percentile(errors_ms, 99)" in lines[0], lines


def test_a_nearest_rank_or_signed_jitter_shows_beside_numpys_with_its_cause():
    nearest = float(np.sort(ERRORS_MS)[int(np.ceil(0.99 * ERRORS_MS.size)) - 1])
    signed = float(np.percentile((PERIODS_S - NOMINAL_S) * 1000, 99))
    for got, cause in ((nearest, "another definition"), (signed, "absolute error")):
        lines = jitter_lines(got, TIMES_S, NOMINAL_S)
        assert len(lines) == 2 and "they differ" in lines[1] and cause in lines[1], lines


def test_a_spread_without_the_log_is_named_under_the_fit():
    rng = np.random.default_rng(1)
    samples = 5.0 + 4.0 * np.exp(0.6 * rng.standard_normal(60))
    above = samples - samples.min()
    said = " ".join(fit_problems((samples.min(), float(np.median(above)), float(np.std(above) / np.median(above))),
                                 samples))
    assert "without the log" in said and "take the log first" in said, said
