"""A classical swing-up (energy pumping + LQR, or the minimum-time plan) run from the laptop, on the twin or a
rig, and judged by the kit's rule as a learned policy is (`pendkit eval --controller`).

The controller is designed for the env it runs on (its step, delays and servo), as the demo does; on a rig
that is the rig's parameters (`--params` or a preset) behind the assumed network latency."""

from __future__ import annotations

from collections.abc import Callable

import pendkit
from pendkit.agents.policy_rule import RULE_STARTS, PolicyVerdict
from pendkit.agents.runs import SOLVED_TAIL_STEPS, Evaluation, held_fraction
from pendkit.episode import run_episode
from pendkit.features import holds_upright, time_to_upright_s
from pendkit.rig import RigParams


def controller_env(params: RigParams, backend: str = "sim", rig: str = "r01", broker: str | None = None,
                   rig_options: dict | None = None):
    """The env a classical controller runs on: continuous actions, no env filter (the controller smooths its own
    targets); the realistic twin, or the rig over MQTT."""
    options = {"backend": "rig", "rig": rig, "broker": broker, "rig_options": rig_options} if backend == "rig" else {}
    return pendkit.make(action_mode="continuous", filter_coefficient=0.0, fidelity="realistic", params=params,
                        **options)


def judge_controller(env, name: str, starts: list[str | None], seed: int,
                     say: Callable[[str], None] | None = None) -> Evaluation:
    """One episode per entry of `starts` (None: as the env starts, e.g. a rig hanging still), episode k from
    seed `seed + k`; each judged by the rule's tail (held within 0.3 rad of upright for its last 200 steps)."""
    from pendkit.demo import CONTROLLERS

    controller = CONTROLLERS[name](env)
    outcome = Evaluation([], [], [], [])
    for k, start in enumerate(starts):
        trace = run_episode(env, controller, seed=seed + k, options={"start": start} if start else None)
        angles = trace.pendulum_from_upright_rad
        held = holds_upright(angles, SOLVED_TAIL_STEPS)
        upright_s = time_to_upright_s(angles, env.unwrapped.dt)
        outcome += Evaluation([held], [upright_s], [trace.episode_return], [held_fraction(angles)])
        if say is not None:
            where = f"from {start}" if start else "from rest"
            shown = f"held, upright after {upright_s:.2f} s" if held else "not held"
            say(f"episode {k + 1}/{len(starts)} {where}: {shown}")
    return outcome


def rule_verdict(outcome: Evaluation, starts: list[str | None], seed: int) -> PolicyVerdict | None:
    """The rule's verdict over the first ten episodes when they are the rule's starts (or a rig's, all from
    rest); None when fewer were run."""
    if len(starts) < len(RULE_STARTS):
        return None
    first = Evaluation(*(getattr(outcome, name)[:len(RULE_STARTS)]
                         for name in ("solved", "upright_s", "returns", "held_fractions")))
    return PolicyVerdict(first, tuple(starts[:len(RULE_STARTS)]), seed)
