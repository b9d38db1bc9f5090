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


def yours_against_the_kit(period_s, zeta, fit) -> list[str]:
    """Lines saying what the student's period and damping ratio give, against the kit's `FreeSwingFit`."""
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
    if zeta > 0 and abs(fit.damping_ratio / zeta - math.log(10)) < 0.3:
        lines.append("  your zeta is the kit's over ln(10): use the natural logarithm (np.log), not log10")
    elif zeta > 3 * fit.damping_ratio:
        lines.append("  your zeta is far above the kit's: is it the log decrement itself, not yet converted?")
    return lines
