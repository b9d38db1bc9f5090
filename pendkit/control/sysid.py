"""System identification from logs: the pendulum's natural frequency and damping from a free swing,
the servo's lag and slew rate from step responses, each with a standard error.

Works on any arrays of times and angles: a twin episode, `pendkit.telemetry.log.readings_from_log` of a rig's
or the realistic twin's episode log, or the labs' sampled swings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pendkit.errors import ConfigError


@dataclass(frozen=True)
class FreeSwingFit:
    natural_frequency_rad_s: float
    natural_frequency_se: float
    damping_ratio: float
    damping_ratio_se: float
    decay_rate_per_s: float
    cycles: int

    @property
    def period_s(self) -> float:
        return 2 * math.pi / self.natural_frequency_rad_s


def identify_free_swing(times_s, angles_from_bottom_rad, min_amplitude_rad: float = 0.03) -> FreeSwingFit:
    """Fit a damped swing: period from upward zero crossings (corrected for amplitude), decay rate from a
    straight-line fit of log peak amplitude against time.

    Large swings are slower than small ones (T = T0 (1 + A^2/16 + ...)); each cycle's period is scaled
    back to small amplitude with its own peak. Peaks below `min_amplitude_rad` (a few encoder counts)
    are left out: quantisation dominates them.
    """
    t = np.asarray(times_s, dtype=float)
    angle = (np.asarray(angles_from_bottom_rad, dtype=float) + math.pi) % (2 * math.pi) - math.pi
    if t.shape != angle.shape or t.size < 10:
        raise ConfigError("need matching arrays of at least 10 times and angles")
    if np.max(np.abs(angle)) > 2.5:
        raise ConfigError("the pendulum went over the top: identify from a swing that stays below horizontal")
    up = np.nonzero((angle[:-1] < 0) & (angle[1:] >= 0))[0]
    crossings = t[up] - angle[up] * (t[up + 1] - t[up]) / (angle[up + 1] - angle[up])
    peaks_t, peaks_a = [], []
    for start, stop in zip(up[:-1], up[1:]):
        segment = slice(start, stop + 1)
        k = start + int(np.argmax(np.abs(angle[segment])))
        peaks_t.append(t[k])
        peaks_a.append(float(np.max(np.abs(angle[segment]))))
    usable = [i for i, a in enumerate(peaks_a) if a >= min_amplitude_rad]
    if len(usable) < 3:
        raise ConfigError(f"need at least 3 full cycles above {min_amplitude_rad} rad, found {len(usable)}")
    amplitudes = np.array(peaks_a)[usable]
    periods = np.diff(crossings)[usable] / (1 + amplitudes**2 / 16 + 11 * amplitudes**4 / 3072)
    damped = 2 * math.pi / periods
    slope, slope_se = _line_fit(np.array(peaks_t)[usable], np.log(amplitudes))
    decay = -slope
    omega_d, omega_d_se = float(np.mean(damped)), float(np.std(damped, ddof=1) / math.sqrt(len(damped)))
    omega0 = math.sqrt(omega_d**2 + decay**2)
    return FreeSwingFit(omega0, omega_d_se, decay / omega0, slope_se / omega0, decay, len(usable))


def _line_fit(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Slope and its standard error of a least-squares line."""
    design = np.column_stack([x, np.ones_like(x)])
    coefficients, residuals, *_ = np.linalg.lstsq(design, y, rcond=None)
    dof = max(1, len(x) - 2)
    residual = float(residuals[0]) if residuals.size else float(np.sum((design @ coefficients - y) ** 2))
    variance = residual / dof
    slope_se = math.sqrt(variance / max(np.sum((x - x.mean()) ** 2), 1e-12))
    return float(coefficients[0]), slope_se


@dataclass(frozen=True)
class ServoStepFit:
    lag_s: float
    slew_rate_rad_s: float
    lag_se: float
    slew_rate_se: float
    steps: int


def identify_servo_steps(times_s, commanded_rad, arm_rad, min_step_rad: float = 0.2) -> ServoStepFit:
    """Lag (command change to 10 % of the way) and slew rate (slope from 10 % to 90 %, each crossing
    interpolated between samples) of every command step larger than `min_step_rad`, averaged, with
    standard errors (the sampling period bounds them when there is only one step).

    The arm angle must be measured: on the twin it is the true joint angle; a hobby servo reports
    none, so on a rig it needs an outside measurement (a camera, or a servo with a feedback wire).
    """
    t, command, arm = (np.asarray(v, dtype=float) for v in (times_s, commanded_rad, arm_rad))
    if not (t.shape == command.shape == arm.shape) or t.size < 5:
        raise ConfigError("need matching arrays of times, commands and arm angles")
    jumps = np.nonzero(np.abs(np.diff(command)) >= min_step_rad)[0] + 1
    lags, slews = [], []
    bounds = [*jumps[1:], t.size]
    for start, stop in zip(jumps, bounds):
        before, after = arm[start - 1], command[start]
        span = after - before
        progress = (arm[start:stop] - before) / span
        t_seg = t[start:stop]
        hit10, hit90 = np.argmax(progress >= 0.1), np.argmax(progress >= 0.9)
        if progress.max() < 0.9 or hit90 <= hit10:
            continue  # the next step came before this one finished
        t10, t90 = (_crossing_time(t_seg, progress, hit, level) for hit, level in ((hit10, 0.1), (hit90, 0.9)))
        lags.append(t10 - t[start])
        slews.append(abs(0.8 * span) / max(t90 - t10, 1e-9))
    if not slews:
        raise ConfigError(f"no complete command steps of at least {min_step_rad} rad in the data")
    sample = float(np.median(np.diff(t)))
    lag_se = float(np.std(lags, ddof=1) / math.sqrt(len(lags))) if len(lags) > 1 else sample
    slew_se = float(np.std(slews, ddof=1) / math.sqrt(len(slews))) if len(slews) > 1 else float(np.mean(slews)) * sample
    return ServoStepFit(float(np.mean(lags)), float(np.mean(slews)), max(lag_se, sample / math.sqrt(12)),
                        slew_se, len(slews))


def _crossing_time(t: np.ndarray, progress: np.ndarray, hit: int, level: float) -> float:
    """When `progress` reached `level`, interpolated between the sample before `hit` and `hit`."""
    if hit == 0:
        return float(t[0])
    fraction = (level - progress[hit - 1]) / (progress[hit] - progress[hit - 1])
    return float(t[hit - 1] + fraction * (t[hit] - t[hit - 1]))
