"""A live episode view: the rig drawn (or rendered), with angle, velocity and action traces as it runs."""

from __future__ import annotations

import io
import math

import numpy as np

from pendkit.episode import PALETTE, EpisodeTrace, Policy, run_episode
from pendkit.sim.render import DrawnFrames
from pendkit.widgets.common import figure_png, live_frontend, trace_alt_text, trace_png


def live_traces_png(times_s, angles_deg, velocities_rad_s, actions) -> bytes:
    """Small traces of the episode so far: angle from upright, pendulum rate, action."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    figure = Figure(figsize=(5, 3.6), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.subplots(3, 1, sharex=True)
    for axis, values, colour, label in ((axes[0], angles_deg, PALETTE["pendulum"], "from upright (deg)"),
                                        (axes[1], velocities_rad_s, PALETTE["arm"], "rate (rad/s)"),
                                        (axes[2], actions, PALETTE["action"], "action")):
        axis.plot(times_s, values, color=colour)
        axis.set_ylabel(label, fontsize=8)
    axes[2].set_xlabel("time (s)", fontsize=8)
    return figure_png(figure)


def frame_png(frames: DrawnFrames, arm_rad: float, pendulum_rad: float) -> bytes:
    """One drawn frame of the rig as PNG (works with or without OpenGL)."""
    from PIL import Image

    buffer = io.BytesIO()
    Image.fromarray(frames.frame(arm_rad, pendulum_rad)).save(buffer, format="PNG")
    return buffer.getvalue()


class LiveEpisodeView:
    """Runs `policy` on `env` and redraws every `every` steps: the rig, and the traces so far."""

    def __init__(self, env, policy: Policy, title: str = "Episode", every: int = 5) -> None:
        self.env, self.policy, self.title, self.every = env, policy, title, every
        self.frames = DrawnFrames(env.unwrapped.params, 320, 240)
        self.trace: EpisodeTrace | None = None
        self.widget = None
        if live_frontend():
            import ipywidgets as w

            self.picture = w.Image(format="png")
            self.traces = w.Image(format="png")
            self.text = w.HTML("")
            self.widget = w.VBox([w.HBox([self.picture, self.traces]), self.text])

    def run(self, steps: int | None = None, seed: int | None = 0) -> EpisodeTrace:
        from IPython.display import Image, display

        if self.widget is not None:
            display(self.widget)
        count = [0]
        dt = self.env.unwrapped.dt
        history: dict[str, list[float]] = {"t": [], "angle": [], "rate": [], "action": []}

        def watched(observation, state):
            action = self.policy(observation, state)
            history["t"].append(count[0] * dt)
            history["angle"].append(math.degrees((state.pendulum_angle_rad % (2 * math.pi)) - math.pi))
            history["rate"].append(state.pendulum_velocity_rad_s)
            history["action"].append(float(np.asarray(action, dtype=float).reshape(-1)[0]))
            count[0] += 1
            if self.widget is not None and count[0] % self.every == 0:
                self._update(state)
                if count[0] % (4 * self.every) == 0:  # plotting costs more than drawing: less often
                    self.traces.value = live_traces_png(history["t"], history["angle"], history["rate"],
                                                        history["action"])
            return action

        if hasattr(self.policy, "reset"):
            watched.reset = self.policy.reset
        self.trace = run_episode(self.env, watched, seed=seed, steps=steps)
        if self.widget is not None:
            self.traces.value = trace_png(self.trace, self.title)
            self.text.value = trace_alt_text(self.trace, self.title)
        else:  # no frontend: the finished episode as a static plot and in words
            display(Image(trace_png(self.trace, self.title)))
            print(trace_alt_text(self.trace, self.title))
        return self.trace

    def _update(self, state) -> None:
        true = self.env.unwrapped.backend.true_state() if hasattr(self.env.unwrapped.backend, "true_state") else None
        arm = true["arm_angle_rad"] if true else state.arm_angle_rad
        pendulum = true["pendulum_angle_rad"] if true else state.pendulum_angle_rad
        self.picture.value = frame_png(self.frames, arm, pendulum)
