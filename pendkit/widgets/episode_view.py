"""A live episode view: the rig drawn (or rendered), with angle, velocity and action traces as it runs."""

from __future__ import annotations

import io

from pendkit.episode import EpisodeTrace, Policy, run_episode
from pendkit.sim.render import DrawnFrames
from pendkit.widgets.common import live_frontend, trace_alt_text, trace_png


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

        def watched(observation, state):
            count[0] += 1
            if self.widget is not None and count[0] % self.every == 0:
                self._update(state)
            return self.policy(observation, state)

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
