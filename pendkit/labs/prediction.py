"""Lab 06: a student's `predict_angle` against a pendulum falling from near upright on the ideal twin."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

FALL_START_DEG = 3.0  # released this far from upright, the arm held still
FALL_LIMIT_DEG = 60.0  # judged while the pendulum is within this of upright (the formula is for near upright)
DELAY_STEPS = 2  # the prediction looks this many 60 ms steps ahead: 120 ms, a poor WiFi's loop


@dataclass(frozen=True)
class PredictionRun:
    time_s: np.ndarray  # the times predicted for
    actual_deg: np.ndarray  # the angle from upright then
    ignoring_deg: np.ndarray  # the angle DELAY_STEPS earlier (what a controller ignoring the delay acts on)
    predicted_deg: np.ndarray | None  # the student's prediction made DELAY_STEPS earlier (None: not written)
    delay_s: float
    cause: str = ""  # the prediction's mistake, named from its values where it is a known one

    @staticmethod
    def rms(error_deg: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.square(error_deg))))

    @property
    def ignoring_rms_deg(self) -> float:
        return self.rms(self.ignoring_deg - self.actual_deg)

    @property
    def predicted_rms_deg(self) -> float | None:
        return None if self.predicted_deg is None else self.rms(self.predicted_deg - self.actual_deg)


def falling_pendulum(seed: int = 0):
    """The ideal twin's pendulum falling from FALL_START_DEG with the arm held: (times, angles, velocities,
    step, natural frequency), the true state every 60 ms."""
    import pendkit
    from pendkit.episode import run_episode

    env = pendkit.make(action_mode="continuous", fidelity="ideal")
    start = {"start": "rest", "pendulum_angle_rad": math.pi + math.radians(FALL_START_DEG)}
    trace = run_episode(env, lambda observation, state: 0.0, seed=seed, steps=30, options=start)
    data = trace.as_arrays()
    w0 = env.unwrapped.params.pendulum_natural_frequency_rad_s
    env.close()
    return data["time_s"], data["pendulum_from_upright_rad"], data["pendulum_velocity_rad_s"], \
        float(env.unwrapped.dt), w0


def predictions(predict_angle, seed: int = 0) -> PredictionRun:
    """`predict_angle` (or None) applied DELAY_STEPS ahead along the fall, while within FALL_LIMIT_DEG."""
    from pendkit.grading import attempt

    times, angles, velocities, dt, w0 = falling_pendulum(seed)
    within = np.abs(np.degrees(angles)) < FALL_LIMIT_DEG
    n = int(np.argmin(within)) if not within.all() else len(angles)
    now = np.arange(0, n - DELAY_STEPS)
    delay_s = DELAY_STEPS * dt
    predicted = None
    if predict_angle is not None:
        got = [attempt(predict_angle, float(angles[i]), float(velocities[i]), delay_s, w0) for i in now]
        predicted = None if any(g is None for g in got) else np.degrees(np.asarray(got, dtype=float))
    cause = "" if predicted is None else _cause(angles[now], velocities[now], delay_s, w0, np.radians(predicted))
    return PredictionRun(times[now + DELAY_STEPS], np.degrees(angles[now + DELAY_STEPS]), np.degrees(angles[now]),
                         predicted, delay_s, cause)


def _cause(angles, velocities, delay_s: float, w0: float, predicted) -> str:
    """The grader's words for the first prediction that a known mistake explains, or ""."""
    from pendkit.grading.suites.lab06 import prediction_note

    for theta, rate, got in zip(angles, velocities, predicted):
        note = prediction_note(float(theta), float(rate), delay_s, w0, float(got))
        if note:
            return note
    return ""


def plot_predictions(run: PredictionRun):
    """The angle, what ignoring the delay acts on, and the student's prediction, against time."""
    from pendkit.episode import shown_figure

    figure = shown_figure(figsize=(7, 3.4), layout="constrained")
    axes = figure.subplots()
    axes.plot(run.time_s, run.actual_deg, color="#000000", lw=2, label="the angle when the command lands")
    axes.plot(run.time_s, run.ignoring_deg, color="#D55E00", linestyle="--",
              label=f"ignoring the delay (off by {run.ignoring_rms_deg:.1f} deg rms)")
    if run.predicted_deg is not None:
        axes.plot(run.time_s, run.predicted_deg, color="#0072B2", marker="o", markersize=4, linestyle="none",
                  label=f"your predict_angle (off by {run.predicted_rms_deg:.2f} deg rms)")
    axes.set_xlabel("time (s)")
    axes.set_ylabel("angle from upright (deg)")
    axes.set_title(f"Predicting {1000 * run.delay_s:.0f} ms ahead: the pendulum falling from "
                   f"{FALL_START_DEG:g} deg")
    axes.legend(loc="upper left")
    return figure


def verdict(run: PredictionRun) -> str:
    """One line on the student's prediction, naming the likely cause when it is worse than it should be."""
    if run.predicted_deg is None:
        return "predict_angle is not written yet: only the angle and ignoring the delay are drawn"
    got, ignoring = run.predicted_rms_deg, run.ignoring_rms_deg
    said = f"your prediction is off by {got:.2f} deg rms, ignoring the delay by {ignoring:.1f}"
    if got > 10 * ignoring:
        return said + ": far off the plot; is the delay in seconds (the function gets 0.12, not 120)?"
    if got >= ignoring:
        return said + ": worse than not predicting at all; check the sign of the velocity term"
    if got > 1.0 and run.cause:
        return said + run.cause
    if got > 1.0:
        ahead = float(np.mean((run.predicted_deg - run.actual_deg) * np.sign(run.actual_deg)))
        if ahead < 0:
            return said + (": it falls short of the pendulum: its gravity term is too small or pulls the wrong "
                           "way; gravity pushes it away from upright, so the term is + w0^2 theta d^2 / 2, w0 "
                           "squared")
        return said + ": it overshoots the pendulum; check the gravity term's 1/2"
    return said + ": the prediction lands on the pendulum"
