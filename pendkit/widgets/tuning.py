"""Sliders for the controller's gains that re-run the twin and update the plot (LQR Q and R, swing-up gain)."""

from __future__ import annotations

from dataclasses import dataclass

import pendkit
from pendkit.control.lqr import LqrWeights
from pendkit.control.swingup import SwingUpConfig, SwingUpController
from pendkit.episode import EpisodeTrace, run_episode, time_to_upright_s
from pendkit.widgets.common import live_frontend, trace_alt_text, trace_png


@dataclass(frozen=True)
class TuningResult:
    trace: EpisodeTrace
    time_to_upright_s: float | None
    natural_frequency_rad_s: float


def tuning_run(pendulum_weight: float = 40.0, action_weight: float = 3.0, energy_gain: float = 1.0,
               fidelity: str = "realistic", steps: int = 250, seed: int = 0) -> TuningResult:
    """One swing-up and balance on the twin with these gains (the sliders' callback)."""
    env = pendkit.make(action_mode="continuous", fidelity=fidelity, start="rest", filter_coefficient=0.0)
    controller = SwingUpController.for_env(env, SwingUpConfig(energy_gain=energy_gain),
                                           weights=LqrWeights(pendulum_angle=pendulum_weight, action=action_weight))
    trace = run_episode(env, controller, seed=seed, steps=steps)
    return TuningResult(trace, time_to_upright_s(trace.pendulum_from_upright_rad, env.unwrapped.dt),
                        controller.natural_frequency_rad_s)


def describe(result: TuningResult) -> str:
    upright = (f"upright after {result.time_to_upright_s:.2f} s" if result.time_to_upright_s is not None
               else "not upright at the end")
    return f"{upright}. {trace_alt_text(result.trace, 'Swing-up and balance')}"


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
        self.image = w.Image(value=trace_png(self.result.trace, "Swing-up and balance",
                                             self.result.natural_frequency_rad_s), format="png")
        self.text = w.HTML(describe(self.result))  # the plot in words, for screen readers
        for slider in (self.q, self.r, self.gain):
            slider.observe(self._changed, names="value")
        self.widget = w.VBox([self.q, self.r, self.gain, self.image, self.text])

    def _changed(self, change) -> None:
        self.result = tuning_run(self.q.value, self.r.value, self.gain.value, self.fidelity, self.steps)
        self.image.value = trace_png(self.result.trace, "Swing-up and balance", self.result.natural_frequency_rad_s)
        self.text.value = describe(self.result)

    def show(self):
        from IPython.display import Image, display

        if self.widget is not None:
            display(self.widget)
        else:  # no frontend: the static plot and its description
            display(Image(trace_png(self.result.trace, "Swing-up and balance", self.result.natural_frequency_rad_s)))
            print(describe(self.result))
