"""Rigs a policy has not been trained on, and how it fares on them: the five servo presets and rigs drawn
from ranges wider than training (`pendkit.sim.randomize.held_out_rigs`), each on the realistic twin, from
rest and from the authors' random starts.

A rig here is a `RandomRig` (parameters, network, calibration error), so the presets and drawn rigs run
through the same code; `bench_transfer.py` and `pendkit adapt` use it.
"""

from __future__ import annotations

from pendkit.agents.learners import learner
from pendkit.agents.runs import Evaluation, RunSpec, build_run, evaluate_agent
from pendkit.env import OBSERVED_SOURCES
from pendkit.rig import SERVO_PRESETS, RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS
from pendkit.sim.randomize import RandomRig, held_out_rigs, observer_bank  # noqa: F401 - observer_bank re-exported

HELD_OUT_SEED = 2026  # the documented draw of held-out rigs (docs/adapt.md)
VALIDATION_SEED = 77  # rigs from the training ranges that choose a checkpoint; never the held-out ones


def preset_rigs() -> dict[str, RandomRig]:
    """The servo presets as rigs on the realistic twin's own network."""
    return {name: RandomRig(RigParams.preset(name), None, 0) for name in sorted(SERVO_PRESETS)}


def random_rigs(count: int = 10, seed: int = HELD_OUT_SEED) -> dict[str, RandomRig]:
    return {f"random-{k:02d}": rig for k, rig in enumerate(held_out_rigs(count, seed))}


def validation_rigs(count: int = 8, seed: int = VALIDATION_SEED, after: int = 0) -> dict[str, RandomRig]:
    """Rigs drawn from the training ranges themselves, to choose between checkpoints of a robust policy.
    `after`: the `count` drawn after the first `after` (fresh rigs for a choice made after checkpoints were
    kept by those)."""
    rigs = held_out_rigs(count + after, seed, widening=1.0)
    return {f"validation-{k:02d}": rigs[k] for k in range(after, after + count)}


def unknown_rig_observer(spec: RunSpec) -> dict:
    """`pendkit.make`'s observer option for `spec`'s learner on a rig the laptop does not know: none for a
    learner without an observer, the `observer_bank` for one trained with observers told each rig or with the
    bank itself (`spec.observer` "rig" or "bank"), else the nominal rig's observer (what it was trained with)."""

    if learner(spec.learner).features not in OBSERVED_SOURCES:
        return {}
    return {"observer_params": observer_bank() if spec.observer in ("rig", "bank") else RigParams()}


def rig_env(rig: RandomRig, spec: RunSpec | None = None, observer_knows_rig: bool = False, **env_options):
    """The realistic twin of `rig`, made for `spec`'s learner (or a plain continuous env without one). A
    learner reading the observer's estimate gets an observer designed for the nominal rig (the laptop does
    not know the rig's parameters; a policy trained with observers told each rig, `spec.observer == "rig"`,
    gets the `observer_bank` instead), or for the rig itself with `observer_knows_rig` (what identifying it
    perfectly would give)."""
    import pendkit

    fidelity = rig.fidelity(FIDELITY_PRESETS["realistic"])
    kwargs = learner(spec.learner).env_kwargs() if spec is not None else {}
    if observer_knows_rig and kwargs.get("features") in OBSERVED_SOURCES:
        env_options.setdefault("observer_params", rig.params)
    elif not observer_knows_rig and spec is not None:
        env_options = {**unknown_rig_observer(spec), **env_options}
    env = pendkit.make(fidelity=fidelity, params=rig.params, **kwargs, **env_options)
    return learner(spec.learner).wrap(env) if spec is not None else env


def policy_on_rigs(spec: RunSpec, state: dict, rigs: dict[str, RandomRig], starts: int = 5,
                   seed: int = 10_000, wrap=None, observer_knows_rig: bool = False) -> dict[str, Evaluation]:
    """Greedy episodes of a trained agent on each rig: one from rest, then `starts` random starts. `wrap`: a
    wrapper the agent's env had in training (an ablation's extra observation); `observer_knows_rig`: see
    `rig_env`."""
    outcomes = {}
    for name, rig in rigs.items():
        env = rig_env(rig, spec, observer_knows_rig)
        env = env if wrap is None else wrap(env)
        _, agent, inputs = build_run(spec, env)
        agent.load_state_dict(state)
        outcomes[name] = evaluate_agent(env, agent, inputs, 1 + starts, seed, ["rest"] + ["random"] * starts)
        env.close()
    return outcomes


def summary(outcomes: dict[str, Evaluation]) -> dict:
    """All rigs together: solved share, median time to upright of the solved, their worst held fraction, the
    mean return."""
    together = sum(outcomes.values(), Evaluation([], [], [], []))
    return {"episodes": len(together.solved), "solved": sum(together.solved),
            "solved_share": sum(together.solved) / max(1, len(together.solved)),
            "median_upright_s": together.median_upright_s, "min_held_fraction": together.min_held_fraction,
            "mean_return": sum(together.returns) / max(1, len(together.returns))}
