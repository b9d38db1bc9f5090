"""Lab 02: how far each of the student's velocity estimates is from the truth, and from the firmware's own."""

from __future__ import annotations

import numpy as np

from pendkit import encoder

MEAN_WINDOW = 4
ALPHA = 0.2  # the plot's low-pass: small enough that 1 - alpha (0.8) looks plainly different


def rms(a, b) -> float:
    return float(np.sqrt(np.mean(np.square(np.asarray(a, float) - np.asarray(b, float)))))


def _reference_mean(raw: np.ndarray) -> np.ndarray:
    padded = np.concatenate([np.zeros(MEAN_WINDOW - 1), raw])
    return np.convolve(padded, np.ones(MEAN_WINDOW) / MEAN_WINDOW, mode="valid")


def notes(true_rev_s, raw, mean, smooth, readings=None) -> list[str]:
    """One line per estimate the student has written: its RMS error against the truth, and where it parts
    from the estimate it should be, with the likely cause. `readings` (the twin's log: raw_counts, times_ms)
    lets the single differences be held to the firmware's own."""
    true_rev_s = np.asarray(true_rev_s, float)
    lines = []
    if raw is None:
        return lines
    raw = np.asarray(raw, float)
    line = f"single differences: {rms(raw, true_rev_s):.3f} rev/s rms from the truth"
    if readings is not None:
        from pendkit.grading.suites.lab02 import velocity_note

        want = encoder.finite_difference_rev_s(readings.raw_counts, readings.times_ms)
        if raw.shape != want.shape:
            line += f"; there should be {len(want)} of them, one per pair of readings"
        elif not np.allclose(raw, want, atol=1e-9):
            line += "; they differ from the firmware's" + (velocity_note(raw, want, readings.raw_counts,
                                                                        readings.times_ms) or "")
    lines.append(line)
    if mean is not None:
        mean, want = np.asarray(mean, float), _reference_mean(raw)
        line = f"your firmware_mean: {rms(mean, true_rev_s):.3f} rev/s rms from the truth"
        if mean.shape == true_rev_s.shape:
            full = slice(MEAN_WINDOW - 1, None)
            line += (f" ({rms(mean[full], true_rev_s[full]):.3f} from its {MEAN_WINDOW}th value on, once the buffer "
                     "is full: what the period sweep below scores)")
        wrong = np.flatnonzero(~np.isclose(mean, want)) if mean.shape == want.shape else np.arange(len(want))
        if len(wrong) and wrong.max() < MEAN_WINDOW - 1:
            line += (f"; its first {wrong.max() + 1} values differ from the firmware's, whose buffer starts full "
                     "of zeros (see the plot's first 0.1 s)")
        elif len(wrong) and mean.shape == want.shape and np.allclose(mean[:-1], want[1:]):
            line += "; it runs ahead of the firmware's: it uses values that have not arrived yet"
        elif len(wrong):
            line += "; it differs from the firmware's mean of the last 4"
        lines.append(line)
    if smooth is not None:
        smooth = np.asarray(smooth, float)
        line = f"your low_pass (alpha {ALPHA}): {rms(smooth, true_rev_s):.3f} rev/s rms from the truth"
        if smooth.shape == raw.shape and np.allclose(smooth, encoder.low_pass(raw, 1 - ALPHA)):
            line += f"; that is a low-pass with alpha {1 - ALPHA:g}: alpha and 1 - alpha are swapped"
        elif smooth.shape != raw.shape or not np.allclose(smooth, encoder.low_pass(raw, ALPHA)):
            from pendkit.grading.suites.lab02 import low_pass_note

            line += f"; it differs from y_k = y_(k-1) + {ALPHA} (x_k - y_(k-1))" + low_pass_note(raw, ALPHA, smooth)
        lines.append(line)
    return lines
