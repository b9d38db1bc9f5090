"""Sliders for the controller's gains that re-run the twin and update the plots (LQR Q and R, swing-up gain).

Beside the whole episode, a zoom on the balance phase (pendulum and arm in degrees) and the numbers that
Q and R change: the gain K, the largest closed-loop pole, the balance error and how far the arm travels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import pendkit
from pendkit.control.lqr import LqrWeights
from pendkit.control.swingup import SwingUpConfig, SwingUpController
from pendkit.episode import PALETTE, EpisodeTrace, run_episode, time_to_upright_s
from pendkit.widgets.common import figure_png, live_frontend, trace_alt_text, trace_png


@dataclass(frozen=True)
class TuningResult:
    trace: EpisodeTrace
    time_to_upright_s: float | None
    natural_frequency_rad_s: float
    gain: np.ndarray  # the LQR's K (design state: arm, pendulum, their rates, the filtered target)
    largest_pole: float  # magnitude of the closed loop's slowest pole (< 1: stable)
    dt_s: float

    def balance_slice(self) -> slice | None:
        """The final upright stretch, once the catch has settled (half a second after it begins)."""
        if self.time_to_upright_s is None:
            return None
        start = int(round((self.time_to_upright_s + 0.5) / self.dt_s))
        return slice(start, None) if start < len(self.trace.time_s) - 5 else None

    @property
    def balance_error_deg(self) -> float | None:
        part = self.balance_slice()
        if part is None:
            return None
        return float(np.degrees(np.sqrt(np.mean(np.square(self.trace.pendulum_from_upright_rad[part])))))

    @property
    def arm_travel_deg(self) -> float | None:
        part = self.balance_slice()
        if part is None:
            return None
        arm = np.degrees(np.asarray(self.trace.arm_angle_rad[part]))
        return float(arm.max() - arm.min())


def tuning_run(pendulum_weight: float = 40.0, action_weight: float = 3.0, energy_gain: float = 1.0,
               fidelity: str = "realistic", steps: int = 250, seed: int = 0) -> TuningResult:
    """One swing-up and balance on the twin with these gains (the sliders' callback)."""
    env = pendkit.make(action_mode="continuous", fidelity=fidelity, start="rest", filter_coefficient=0.0)
    controller = SwingUpController.for_env(env, SwingUpConfig(energy_gain=energy_gain),
                                           weights=LqrWeights(pendulum_angle=pendulum_weight, action=action_weight))
    trace = run_episode(env, controller, seed=seed, steps=steps)
    balancer = controller.balancer
    return TuningResult(trace, time_to_upright_s(trace.pendulum_from_upright_rad, env.unwrapped.dt),
                        controller.natural_frequency_rad_s, np.asarray(balancer.gain).reshape(-1),
                        float(np.max(np.abs(balancer.closed_loop_poles))), env.unwrapped.dt)


def describe(result: TuningResult) -> str:
    """The numbers and the plots in words (also for screen readers)."""
    upright = (f"upright after {result.time_to_upright_s:.2f} s" if result.time_to_upright_s is not None
               else "not upright at the end")
    design = (f"K = [{', '.join(f'{k:.2f}' for k in result.gain)}]; largest closed-loop pole "
              f"|z| = {result.largest_pole:.3f}")
    if result.balance_error_deg is None:
        balance = "no settled balance phase to measure"
    else:
        balance = (f"balancing: pendulum {result.balance_error_deg:.2f} deg RMS, arm travels over "
                   f"{result.arm_travel_deg:.1f} deg")
    return f"{upright}. {design}. {balance}. {trace_alt_text(result.trace, 'Swing-up and balance')}"


def balance_png(result: TuningResult) -> bytes:
    """The balance phase, zoomed: pendulum and arm in degrees."""
    from matplotlib.figure import Figure

    figure = Figure(figsize=(6, 3), layout="constrained")
    axis = figure.subplots()
    part = result.balance_slice()
    if part is None:
        axis.text(0.5, 0.5, "no settled balance phase", ha="center", va="center", transform=axis.transAxes)
    else:
        time = np.asarray(result.trace.time_s[part])
        axis.plot(time, np.degrees(result.trace.pendulum_from_upright_rad[part]), color=PALETTE["pendulum"],
                  label="pendulum from upright")
        axis.plot(time, np.degrees(result.trace.arm_angle_rad[part]), color=PALETTE["arm"], linestyle="--",
                  label="arm")
        axis.legend(loc="upper right")
        axis.set_title(f"balance: {result.balance_error_deg:.2f} deg RMS, arm over {result.arm_travel_deg:.1f} deg")
    axis.set_xlabel("time (s)")
    axis.set_ylabel("angle (deg)")
    return figure_png(figure)


class GainTuner:
    """Three sliders (pendulum-angle weight Q, action weight R, swing-up gain) and the episode they give."""

    def __init__(self, fidelity: str = "realistic", steps: int = 250) -> None:
        self.fidelity, self.steps = fidelity, steps
        self.result = tuning_run(fidelity=fidelity, steps=steps)
        self.widget = None
        if live_frontend():
            self._build()

    def _build(self) -> None:
        import ipywidgets as w

        style = {"description_width": "14em"}
        layout = w.Layout(width="36em")
        common = {"style": style, "layout": layout, "continuous_update": False}
        self.q = w.FloatLogSlider(value=40.0, base=10, min=0, max=3, step=0.1, description="Q pendulum angle",
                                  **common)
        self.r = w.FloatLogSlider(value=3.0, base=10, min=-1, max=2, step=0.1, description="R action", **common)
        self.gain = w.FloatSlider(value=1.0, min=0.2, max=4.0, step=0.1, description="swing-up energy gain",
                                  **common)
        # scaled to the notebook's width (a PNG image widget is otherwise drawn at its pixel size: the zoom
        # beside the episode ran off the right edge)
        self.image = w.Image(format="png", layout=w.Layout(width="60%", height="auto"))
        self.zoom = w.Image(format="png", layout=w.Layout(width="40%", height="auto"))
        self.text = w.HTML()  # the plots in words, for screen readers
        self._show_result()
        for slider in (self.q, self.r, self.gain):
            slider.observe(self._changed, names="value")
        row = w.HBox([self.image, self.zoom], layout=w.Layout(width="100%", align_items="flex-start"))
        self.widget = w.VBox([self.q, self.r, self.gain, row, self.text])

    def _show_result(self) -> None:
        self.image.value = trace_png(self.result.trace, "Swing-up and balance", self.result.natural_frequency_rad_s)
        self.zoom.value = balance_png(self.result)
        self.text.value = describe(self.result)

    def _changed(self, change) -> None:
        self.result = tuning_run(self.q.value, self.r.value, self.gain.value, self.fidelity, self.steps)
        self._show_result()

    def show(self):
        from IPython.display import Image, display

        if self.widget is not None:
            display(self.widget)
        else:  # no frontend: the static plots and their description
            display(Image(trace_png(self.result.trace, "Swing-up and balance", self.result.natural_frequency_rad_s)))
            display(Image(balance_png(self.result)))
            print(describe(self.result))
