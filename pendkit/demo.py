"""`pendkit demo`: swing up and balance on the twin with a classical controller; plot and animate.

Controllers: the classical swing-ups of `pendkit.deploy.controllers` ("energy", energy pumping caught by LQR;
"trajopt", the minimum-time plan tracked by time-varying LQR, its plans drawn over the measured angle; ...)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

import pendkit
from pendkit.deploy.controllers import DEFAULT_CONTROLLER, controller_named
from pendkit.episode import EpisodeTrace, plot_episode, run_episode, time_to_upright_s

ANIMATION_SECONDS = 6.0


@dataclass
class DemoResult:
    trace: EpisodeTrace
    time_to_upright_s: float | None
    plot_path: Path
    animation_path: Path | None


def run_demo(fidelity: str = "realistic", seed: int = 0, start: str = "rest", out_dir: Path = Path("pendkit-output"),
             progress: bool = True, animate: bool = True, controller_name: str = "energy") -> DemoResult:
    """One episode of swing-up and balance; a plot (angles, action, reward, energy) and a GIF of its start."""
    chosen = controller_named(controller_name)  # ConfigError naming the known ones
    env = pendkit.make(action_mode="continuous", fidelity=fidelity, start=start, filter_coefficient=0.0,
                       render_mode="rgb_array" if animate else None)
    controller = chosen.host(env)
    frames: list[np.ndarray] = []
    frame_steps = max(1, round(0.12 / env.unwrapped.dt))  # about 8 frames per second of rig time
    last_frame_step = int(ANIMATION_SECONDS / env.unwrapped.dt)

    def policy(observation, state):
        step = len(frames_seen)
        frames_seen.append(step)
        if animate and step <= last_frame_step and step % frame_steps == 0:
            frames.append(env.render())
        return controller(observation, state)

    policy.reset = controller.reset  # run_episode starts stateful controllers afresh
    frames_seen: list[int] = []
    trace = run_episode(env, policy, seed=seed, progress=progress)
    env.close()
    out_dir.mkdir(parents=True, exist_ok=True)
    stem = f"demo-{fidelity}-seed{seed}" + ("" if controller_name == DEFAULT_CONTROLLER else f"-{controller_name}")
    plot_path = out_dir / f"{stem}.png"
    plot_episode(trace, plot_path, title=f"{chosen.title} on the twin ({fidelity})",
                 natural_frequency_rad_s=controller.natural_frequency_rad_s,
                 decorate=lambda axes: _draw_plans(axes[0], getattr(controller, "plans", []), trace))
    animation_path = None
    if animate and frames:
        animation_path = out_dir / f"{stem}.gif"
        _write_gif(frames, animation_path, frame_ms=round(frame_steps * env.unwrapped.dt * 1000),
                   description=f"The rig's twin swinging up and balancing, the first {ANIMATION_SECONDS:g} s "
                               f"of the episode ({fidelity} fidelity).")
    return DemoResult(trace, time_to_upright_s(trace.pendulum_from_upright_rad, env.unwrapped.dt), plot_path,
                      animation_path)


def _draw_plans(axis, plans, trace: EpisodeTrace) -> None:
    """Each plan's pendulum |angle from upright| (degrees, as the episode plot), dotted, from the step it was made."""
    times = np.asarray(trace.time_s)
    for number, plan in enumerate(plans):
        start_s = plan.notes.get("made_at_s", 0.0)
        planned = np.degrees(np.abs(plan.states[:, 1] % (2 * np.pi) - np.pi))
        axis.plot(start_s + np.arange(len(planned)) * plan.period_s, planned, color="black", linestyle=":",
                  lw=1.2, label="plan" if number == 0 else None)
    if plans:
        axis.set_xlim(times[0], times[-1])
        axis.legend(loc="upper right", fontsize=8)


def _write_gif(frames: list[np.ndarray], path: Path, frame_ms: int, description: str) -> None:
    from PIL import Image

    images = [Image.fromarray(frame).convert("P", palette=Image.Palette.ADAPTIVE) for frame in frames]
    images[0].save(path, save_all=True, append_images=images[1:], duration=frame_ms, loop=0, optimize=True,
                   comment=description.encode())  # the animation's alt text
