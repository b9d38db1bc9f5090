"""Lab 02: how far each of the student's velocity estimates is from the truth, and from the firmware's own."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pendkit import encoder

MEAN_WINDOW = 4
ALPHA = 0.2  # the plot's low-pass: small enough that 1 - alpha (0.8) looks plainly different


def rms(a, b) -> float:
    return float(np.sqrt(np.mean(np.square(np.asarray(a, float) - np.asarray(b, float)))))


def _reference_mean(raw: np.ndarray) -> np.ndarray:
    padded = np.concatenate([np.zeros(MEAN_WINDOW - 1), raw])
    return np.convolve(padded, np.ones(MEAN_WINDOW) / MEAN_WINDOW, mode="valid")


# what each estimate holds one value per: the words for a wrong count (plural, singular)
ONE_PER = {"velocity_rev_s": ("pairs of readings", "pair"), "firmware_mean": ("velocities", "velocity"),
           "low_pass": ("velocities", "velocity")}


def wrong_length(name: str, values, count: int) -> str:
    """The sentence for `name`'s answer when it has not one value per item (`count` of them; "" when it has):
    the plot cell prints it and leaves that answer out rather than stop on matplotlib's shape error."""
    if np.shape(values) == (count,):
        return ""
    of, each = ONE_PER[name]
    got = f"{len(values)} values" if np.ndim(values) == 1 else f"an array of shape {np.shape(values)}"
    return (f"{name} returned {got} for the {count} {of}: it should return {count}, one per {each}; "
            "the plot leaves it out")


def drawable(name: str, values, count: int, said: list[str]):
    """`values` when `name` returned one per item (`count`), else None with `wrong_length`'s sentence in `said`."""
    if values is None or not (sentence := wrong_length(name, values, count)):
        return values
    said.append(sentence)
    return None


def _wrong_length_in_sweep(name: str, values, count: int) -> str:
    """`wrong_length` in words that hold at every period (the sweep says it once)."""
    if np.shape(values) == (count,):
        return ""
    of, each = ONE_PER[name]
    extra = len(values) - count if np.ndim(values) == 1 else None
    got = f"n {'+' if extra > 0 else '-'} {abs(extra)} values" if extra else f"a {np.ndim(values)}-D array"
    return f"your {name} returns {got} for n {of}, not one per {each}"


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
        from pendkit.grading.suites.lab02 import LATE, one_step_late

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
        elif len(wrong) and one_step_late(mean, want):
            line += "; it differs from the firmware's" + LATE
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


@dataclass(frozen=True)
class SweepPoint:
    """One streaming period of the sweep: the RMS error against the truth, once the buffer is full, of the
    student's `firmware_mean(velocity_rev_s(...), 4)` (None while either is not written) and of the firmware's."""

    period_ms: float
    yours_rev_s: float | None
    firmware_rev_s: float
    note: str = ""  # where yours parts from the firmware's: the notes' words for the cause


def period_sweep(velocity_fn, mean_fn, periods_ms) -> list[SweepPoint]:
    """The lab's swing sampled at each period, its velocity estimated by the student's two functions and by the
    firmware (`pendkit.encoder.firmware_velocity`), each scored from the estimate's `MEAN_WINDOW`th value on."""
    from pendkit.grading import attempt
    from pendkit.sim.lab_readings import firmware_estimate_error_rev_s, free_swing_readings

    points = []
    for period_ms in periods_ms:
        readings = free_swing_readings(period_ms=float(period_ms))
        firmware = firmware_estimate_error_rev_s(float(period_ms))
        true_rev_s = readings.true_velocity_rev_s[1:]
        raw = attempt(velocity_fn, readings.raw_counts, readings.times_ms)
        wrong = "" if raw is None else _wrong_length_in_sweep("velocity_rev_s", raw, len(true_rev_s))
        mean = None if raw is None or wrong else attempt(mean_fn, raw, MEAN_WINDOW)
        if mean is not None:
            wrong = _wrong_length_in_sweep("firmware_mean", mean, len(true_rev_s))
        if mean is None or wrong:
            points.append(SweepPoint(float(period_ms), None, firmware, wrong))
            continue
        mean = np.asarray(mean, float)
        full = slice(MEAN_WINDOW - 1, None)
        yours = rms(mean[full], true_rev_s[full])
        note = ""
        if round(yours, 3) != round(firmware, 3):
            said = notes(true_rev_s, raw, mean, None, readings)
            named = [(line.split(":", 1)[0].removeprefix("your "), line.split("; ", 1)[1])
                     for line in said if "; " in line]  # each estimate's own line under the plot above
            note = "; ".join(f"your {name}: {_cause(why)}" for name, why in named)
        points.append(SweepPoint(float(period_ms), yours, firmware, note))
    return points


def _cause(why: str) -> str:
    """A note's cause without its "they differ from the firmware's" (the sweep's line says so already)."""
    for said in ("they differ from the firmware's: ", "it differs from the firmware's: "):
        if why.startswith(said):
            return why[len(said):]
    return why


def sweep_lines(points: list[SweepPoint]) -> list[str]:
    """The sweep as the notebook prints it: a line per period, then the cause where yours part from the
    firmware's (said once, at the first period it shows)."""
    lines, said = [], set()
    for point in points:
        line = f"{point.period_ms:5.0f} ms: "
        if point.yours_rev_s is not None:
            line += f"yours {point.yours_rev_s:.3f} rev/s RMS, "
        line += f"the firmware's {point.firmware_rev_s:.3f}, {1000 / point.period_ms:5.0f} messages per second"
        lines.append(line)
        if point.note and point.note not in said:
            said.add(point.note)
            lines.append(f"         yours part from the firmware's at {point.note}" if point.yours_rev_s is not None
                         else f"         yours is left out: {point.note}")
    return lines
