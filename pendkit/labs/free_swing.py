"""Lab 03: the student's period and damping functions on the twin's free swing, beside the kit's fit."""

from __future__ import annotations

import math

import numpy as np

MIN_PEAK_RAD = 0.03  # smaller peaks are a few encoder counts: quantisation dominates them


def swing_peaks(times_s, angles_rad) -> np.ndarray:
    """Each full cycle's largest |angle| (between successive upward zero crossings), above MIN_PEAK_RAD."""
    angle = np.asarray(angles_rad, dtype=float)
    up = np.nonzero((angle[:-1] < 0) & (angle[1:] >= 0))[0]
    peaks = [float(np.max(np.abs(angle[start:stop + 1]))) for start, stop in zip(up[:-1], up[1:])]
    return np.array([p for p in peaks if p >= MIN_PEAK_RAD])


def upward_crossings_s(times_s, angles_rad, interpolate: bool = True) -> np.ndarray:
    """Times of the upward zero crossings: interpolated between the samples around each, or (not) the sample
    at or after it."""
    t, a = np.asarray(times_s, dtype=float), np.asarray(angles_rad, dtype=float)
    up = np.nonzero((a[:-1] < 0) & (a[1:] >= 0))[0]
    if not interpolate:
        return t[up + 1]
    return t[up] - a[up] * (t[up + 1] - t[up]) / (a[up + 1] - a[up])


def yours_against_the_kit(period_s, zeta, fit, times_s=None, angles_rad=None) -> list[str]:
    """Lines saying what the student's period and damping ratio give, against the kit's `FreeSwingFit`; with
    the swing itself (`times_s`, `angles_rad`), a period taken without interpolation is named too."""
    if period_s is None or zeta is None:
        return ["write period_from_crossings and damping_ratio above: they drive the first line here"]
    lines = []
    period_s, zeta = float(period_s), float(zeta)
    if math.isfinite(zeta) and -1 < zeta < 0:
        return [f"yours:        zeta = {zeta:.4f} is negative, a swing that grows: the decrement's ratio is upside "
                "down (ln(A_k / A_(k+1)), each peak over the next)"]
    if not (math.isfinite(period_s) and period_s > 0 and math.isfinite(zeta) and 0 <= zeta < 1):
        return [f"yours:        period {period_s:.4g} s and zeta {zeta:.4g} make no swing (a period above 0, "
                "a damping ratio in [0, 1))"]
    omega0 = 2 * math.pi / period_s / math.sqrt(1 - zeta**2)
    lines.append(f"yours:        w0 = {omega0:.3f} rad/s, zeta = {zeta:.4f}  (period {period_s:.4f} s)")
    kit_period = 2 * math.pi / (fit.natural_frequency_rad_s * math.sqrt(1 - fit.damping_ratio**2))
    ratio = period_s / kit_period
    if ratio < 0.6:
        lines.append(f"  your period is {ratio:.2f} of the kit's: count only upward crossings (negative to "
                     "positive), one per period")
    elif abs(ratio - 1) > 0.03:
        lines.append(f"  your period is {100 * (ratio - 1):+.1f}% from the kit's: check the crossings' "
                     "interpolation")
    elif times_s is not None:
        lines += _interpolation_note(period_s, zeta, times_s, angles_rad)
    if zeta > 0 and abs(fit.damping_ratio / zeta - math.log(10)) < 0.3:
        lines.append("  your zeta is the kit's over ln(10): use the natural logarithm (np.log), not log10")
    elif zeta > 3 * fit.damping_ratio:
        lines.append("  your zeta is far above the kit's: is it the log decrement itself, not yet converted?")
    return lines


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
