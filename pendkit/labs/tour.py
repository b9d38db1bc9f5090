"""Lab 00: the student's reward summed over the tour's episode, beside the env's own return."""

from __future__ import annotations

import numpy as np

from pendkit.grading import attempt


def your_return(reward_fn, trace) -> list[str]:
    """A line giving the return `reward_fn(angle_from_upright_rad, velocity_rad_s)` earns over `trace` (an
    `EpisodeTrace`) beside the env's own, and where the two part most with the likely cause; nothing while the
    function is not implemented yet. The trace's first entry is the reset, which earns no reward."""
    from pendkit.grading.suites.lab00 import reward_note

    arrays = trace.as_arrays()
    angles, velocities = arrays["pendulum_from_upright_rad"][1:], arrays["pendulum_velocity_rad_s"][1:]
    kit = arrays["reward"][1:]
    if not len(kit) or attempt(reward_fn, float(angles[0]), float(velocities[0])) is None:
        return []
    yours = np.array([float(reward_fn(float(a), float(w))) for a, w in zip(angles, velocities)])
    line = (f"your reward summed over the episode above: return {yours.sum():.1f} (the plot's title, from the "
            f"env's own reward: {trace.episode_return:.1f})")
    if np.allclose(yours, kit, rtol=0, atol=1e-9):
        return [line + ": the same"]
    k = int(np.argmax(np.abs(yours - kit)))
    theta, omega = float(angles[k]), float(velocities[k])
    return [line + f"; they part most at {arrays['time_s'][k + 1]:.2f} s (angle {theta:.3f} rad, velocity "
                   f"{omega:.3f} rad/s), where yours gives {yours[k]:.4f} and the paper's reward "
                   f"{kit[k]:.4f}" + reward_note(theta, omega, float(yours[k]))]
