"""Rigs a policy has not been trained on, and how it fares on them: the five servo presets and rigs drawn
from ranges wider than training (`pendkit.sim.randomize.held_out_rigs`), each on the realistic twin, from
rest and from the authors' random starts.

A rig here is a `RandomRig` (parameters, network, calibration error), so the presets and drawn rigs run
through the same code; `bench_transfer.py` and `pendkit adapt` use it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pendkit.agents.runs import RunSpec, build_run, greedy_episode, solved
from pendkit.features import UPRIGHT_RAD
from pendkit.rig import SERVO_PRESETS, RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS
from pendkit.sim.randomize import RandomRig, held_out_rigs

HELD_OUT_SEED = 2026  # the documented draw of held-out rigs (docs/rl.md)


def preset_rigs() -> dict[str, RandomRig]:
    """The servo presets as rigs on the realistic twin's own network."""
    return {name: RandomRig(RigParams.preset(name), None, 0) for name in sorted(SERVO_PRESETS)}


def random_rigs(count: int = 10, seed: int = HELD_OUT_SEED) -> dict[str, RandomRig]:
    return {f"random-{k:02d}": rig for k, rig in enumerate(held_out_rigs(count, seed))}


def rig_env(rig: RandomRig, spec: RunSpec | None = None, **env_options):
    """The realistic twin of `rig`, made for `spec`'s learner (or a plain continuous env without one)."""
    import pendkit
    from pendkit.agents.learners import learner

    fidelity = rig.fidelity(FIDELITY_PRESETS["realistic"])
    kwargs = learner(spec.learner).env_kwargs() if spec is not None else {}
    return pendkit.make(fidelity=fidelity, params=rig.params, **kwargs, **env_options)


def held_fraction(angles_from_upright_rad) -> float | None:
    """Of the steps after the pendulum first comes within UPRIGHT_RAD, the fraction that stay within it
    (the balance holds, not wobbles); None if it never comes up."""
    angles = np.abs(np.asarray(angles_from_upright_rad))
    up = np.nonzero(angles < UPRIGHT_RAD)[0]
    if len(up) == 0:
        return None
    return float(np.mean(angles[up[0]:] < UPRIGHT_RAD))


@dataclass(frozen=True)
class Episode:
    rig: str
    start: str
    solved: bool
    upright_s: float | None
    held_fraction: float | None


def policy_on_rigs(spec: RunSpec, state: dict, rigs: dict[str, RandomRig], starts: int = 5,
                   seed: int = 10_000) -> list[Episode]:
    """Greedy episodes of a trained agent on each rig: one from rest and `starts` random starts."""
    from pendkit.episode import time_to_upright_s

    episodes = []
    for name, rig in rigs.items():
        env = rig_env(rig, spec)
        _, agent, inputs = build_run(spec, env)
        agent.load_state_dict(state)
        for k, start in enumerate(["rest"] + ["random"] * starts):
            _, infos = greedy_episode(env, agent, inputs, seed=seed + k, start=start)
            angles = [info["angle_from_upright_rad"] for info in infos]
            episodes.append(Episode(name, start, solved(infos), time_to_upright_s(angles, env.unwrapped.dt),
                                    held_fraction(angles)))
        env.close()
    return episodes


def summary(episodes: list[Episode]) -> dict:
    """Solved share, median time to upright over solved episodes, and the worst held fraction of them."""
    held = [e for e in episodes if e.solved]
    times = [e.upright_s for e in held if e.upright_s is not None]
    return {"episodes": len(episodes), "solved": len(held), "solved_share": len(held) / max(1, len(episodes)),
            "median_upright_s": float(np.median(times)) if times else None,
            "min_held_fraction": min((e.held_fraction for e in held), default=None)}
