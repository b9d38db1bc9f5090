"""Lab 03: the student's period and damping functions on the twin's free swing, beside the kit's fit."""

from __future__ import annotations

import math

import numpy as np

from pendkit.grading.suites.lab03 import count_note, crossing_note, crossings_by

MIN_PEAK_RAD = 0.03  # smaller peaks are a few encoder counts: quantisation dominates them
SE_LIMIT = 3  # how many of the kit's standard errors apart the student's figures are said to part from it


def swing_peaks(times_s, angles_rad) -> np.ndarray:
    """Each full cycle's largest |angle| (between successive upward zero crossings), above MIN_PEAK_RAD."""
    angle = np.asarray(angles_rad, dtype=float)
    up = np.nonzero((angle[:-1] < 0) & (angle[1:] >= 0))[0]
    peaks = [float(np.max(np.abs(angle[start:stop + 1]))) for start, stop in zip(up[:-1], up[1:])]
    return np.array([p for p in peaks if p >= MIN_PEAK_RAD])


def upward_crossings_s(times_s, angles_rad, interpolate: bool = True) -> np.ndarray:
    """Times of the upward zero crossings by the task's rule (a sample below 0, the next at or above 0):
    interpolated between the samples around each, or (not) the sample at or after it."""
    return crossings_by(times_s, angles_rad, interpolate=interpolate)


def yours_against_the_kit(period_s, zeta, fit, times_s=None, angles_rad=None) -> list[str]:
    """Lines saying what the student's period and damping ratio give, against the kit's `FreeSwingFit`. A line
    under them names the cause where the student's figures part from the kit's by more than SE_LIMIT of its
    standard errors, or match a slip on this swing (`times_s`, `angles_rad`): readings of exactly 0.0 skipped
    or crossed from, no interpolation. Where nothing known explains a difference, it says only how far off it is."""
    if period_s is None or zeta is None:
        return ["write period_from_crossings and damping_ratio above: they drive the first line here"]
    period_s, zeta = float(period_s), float(zeta)
    swing = times_s is not None and angles_rad is not None
    if math.isfinite(zeta) and -1 < zeta < 0:
        lines = [f"yours:        period {period_s:.4f} s, zeta = {zeta:.4f}: a negative zeta is a swing that grows, so "
                 "no w0 follows; the decrement's ratio is upside down (ln(A_k / A_(k+1)), each peak over the next)"]
        if math.isfinite(period_s) and period_s > 0:
            lines += (_period_notes(period_s, 0.0, fit, times_s, angles_rad) if swing
                      else _period_notes(period_s, 0.0, fit))
        return lines
    if not (math.isfinite(period_s) and period_s > 0 and math.isfinite(zeta) and 0 <= zeta < 1):
        line = (f"yours:        period {period_s:.4g} s and zeta {zeta:.4g} make no swing (a period above 0, "
                "a damping ratio in [0, 1))")
        note = crossing_note(period_s, times_s, angles_rad) if swing else ""
        return [line] + ([f"  your period{note}"] if note else [])
    omega0 = 2 * math.pi / period_s / math.sqrt(1 - zeta**2)
    lines = [f"yours:        w0 = {omega0:.3f} rad/s, zeta = {zeta:.4f}  (period {period_s:.4f} s)"]
    lines += _period_notes(period_s, zeta, fit, times_s, angles_rad) if swing else _period_notes(period_s, zeta, fit)
    if zeta > 0 and abs(fit.damping_ratio / zeta - math.log(10)) < 0.3:
        lines.append("  your zeta is the kit's over ln(10): use the natural logarithm (np.log), not log10")
    elif zeta > 3 * fit.damping_ratio:
        lines.append("  your zeta is far above the kit's: is it the log decrement itself, not yet converted?")
    elif abs(zeta - fit.damping_ratio) > SE_LIMIT * fit.damping_ratio_se:
        lines.append(f"  your zeta is {(zeta - fit.damping_ratio) / fit.damping_ratio_se:+.0f} of the kit's standard "
                     "errors from its zeta, more than the two methods' difference explains: check damping_ratio "
                     "against the task's formula")
    return lines


def _period_notes(period_s: float, zeta: float, fit, times_s=None, angles_rad=None) -> list[str]:
    """A line naming why the student's period parts from the kit's, or saying only how far, or nothing."""
    kit_period = 2 * math.pi / (fit.natural_frequency_rad_s * math.sqrt(1 - fit.damping_ratio**2))
    standard_errors = (period_s - kit_period) / (kit_period * fit.natural_frequency_se / fit.natural_frequency_rad_s)
    off = (f"your period is {100 * (period_s / kit_period - 1):+.1f}% ({standard_errors:+.0f} standard errors) from "
           "the kit's")
    if period_s / kit_period < 0.6:
        return [f"  your period is {period_s / kit_period:.2f} of the kit's: count only upward crossings (negative "
                "to positive), one per period"]
    if times_s is not None:
        note = crossing_note(period_s, times_s, angles_rad) or count_note(period_s, times_s, angles_rad)
        if note:
            return [f"  {off}{note}"]
        interpolation = _interpolation_note(period_s, zeta, times_s, angles_rad)
        if interpolation:
            return interpolation
    if abs(standard_errors) <= SE_LIMIT:
        return []
    if times_s is None:
        return [f"  {off}: more than the two methods' difference explains; compare your crossings with the task's "
                "rule (below 0, then at or above 0, interpolated)"]
    return [f"  {off}: more than the two methods' difference explains, and none of the usual slips (readings of "
            "exactly 0.0 skipped or crossed from, no interpolation, both directions, dividing by the number of "
            "crossings rather than of periods) gives your period on this "
            "swing: print your crossings' times and compare them with the plot above"]


def _interpolation_note(period_s: float, zeta: float, times_s, angles_rad) -> list[str]:
    """A line for a period taken from crossings at the samples (not interpolated): close to the kit's, and
    within its error, yet not what the task asks."""
    interpolated = float(np.mean(np.diff(upward_crossings_s(times_s, angles_rad))))
    at_samples = float(np.mean(np.diff(upward_crossings_s(times_s, angles_rad, interpolate=False))))
    if abs(period_s - interpolated) < 1e-9 or abs(period_s - at_samples) > 1e-9:
        return []
    omega0 = 2 * math.pi / interpolated / math.sqrt(1 - zeta**2)
    return [f"  your period is the crossings' samples, not interpolated: interpolated it is {interpolated:.4f} s "
            f"(w0 = {omega0:.3f} rad/s); on 25 ms samples the two differ by less than the kit's error, but "
            "coarser samples (the check's 60 ms) show it"]
