"""The two routes from an identified twin to a rig: the learned one (train on the twin from the shipped
robust policy, then fine-tune on the rig with the non-blocking trainer) and the classical one (energy
swing-up + LQR designed on the twin). Both are judged on the rig by the kit's "solved" rule."""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pendkit.adapt.identify import Identification
from pendkit.adapt.uncertainty import AroundTheFit
from pendkit.agents.async_trainer import AsyncTrainer
from pendkit.agents.learners import LEARNER_NAMES, learner
from pendkit.agents.policy_artifact import policy_artifact
from pendkit.agents.pretrained import POLICIES
from pendkit.agents.runs import (
    SOLVED_TAIL_STEPS,
    Evaluation,
    RunSpec,
    build_run,
    evaluate_agent,
    judge_runs,
    judged_episodes,
    save_weights,
)
from pendkit.deploy.controllers import adapt_controllers, controller_named
from pendkit.deploy.learned_blob import DEVICE_LEARNERS, learned_policy_blob
from pendkit.deploy.on_twin import onboard_episode, upload_to_twin
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack
from pendkit.env import OBSERVED_SOURCES
from pendkit.env_name import EPISODE_STEPS
from pendkit.errors import ConfigError
from pendkit.features import holds_upright
from pendkit.network import LatencyModel, NetworkImpairment
from pendkit.rig import RigParams
from pendkit.safe_write import write_bytes
from pendkit.sim.fidelity import FIDELITY_PRESETS
from pendkit.sim.randomize import observer_bank

# pendkit modules that load torch are imported inside the functions that use them: importing this module does not need
# them (start-up; torch is an optional extra).


def identified_twin(identification: Identification, **env_kwargs):
    """The realistic twin of the identified rig behind the network measured with it, or else its latency as
    a fixed floor, no loss."""
    import pendkit

    network = identification.network or NetworkImpairment(LatencyModel(floor_ms=identification.latency_ms))
    fidelity = FIDELITY_PRESETS["realistic"].replace(name="identified", network=network)
    return pendkit.make(fidelity=fidelity, params=identification.params, **env_kwargs)


def starting_weights(name: str) -> tuple[RunSpec, dict | None]:
    """The shipped policy to start from, or (its learner, None) when it is not there or `name` is a learner's
    (`pendkit.agents.learners.LEARNER_NAMES`): trained afresh."""

    if name in LEARNER_NAMES:  # a learner rather than a policy: trained afresh, its observer the identified rig's
        return RunSpec(name, "realistic", observer="rig"), None
    try:
        artifact = policy_artifact(name=name)
        return artifact.spec, artifact.state
    except ConfigError:
        spec = POLICIES[name].run if name in POLICIES else RunSpec("r-dqn", "realistic")
        return dataclasses.replace(spec, randomize=""), None


@dataclass
class AgentRun:
    """A learned policy on its way to the rig; `observer_params`: the rig its observer is designed for (the
    identified one), for a learner reading the observer's estimate."""

    spec: RunSpec
    agent: object
    inputs: object
    observer_params: RigParams | tuple[RigParams, ...] | None = None

    def env_kwargs(self) -> dict:
        kwargs = learner(self.spec.learner).env_kwargs()
        if kwargs.get("features") in OBSERVED_SOURCES and self.observer_params is not None:
            kwargs["observer_params"] = self.observer_params  # what the laptop knows of the rig, not the rig
        return kwargs

    def make_env(self, rig):
        """`rig`'s env as this policy acts on it (a target-level policy through its levels)."""

        return learner(self.spec.learner).wrap(rig.make_env(**self.env_kwargs()))

    def evaluate(self, rig, episodes: int) -> dict:
        if episodes == 0:
            return {"summary": "not evaluated"}
        env = self.make_env(rig)
        outcome = evaluate_agent(env, self.agent, self.inputs, episodes, start=None)
        env.close()
        return _as_report(outcome)


def _as_report(outcome: Evaluation) -> dict:
    return {"solved": outcome.solved, "upright_s": outcome.upright_s, "summary": outcome.summary()}


def twin_env(spec: RunSpec, identification: Identification, observer, spread: dict | None, seed: int):
    """The identified twin as `spec`'s learner acts on it; with `spread`, a rig drawn from it every episode."""

    kwargs = AgentRun(spec, None, None, observer).env_kwargs()
    env = learner(spec.learner).wrap(identified_twin(identification, **kwargs))
    if spread:
        env = AroundTheFit(env, identification, spread, seed=seed, observer_params=observer)
    return env


def train_on_twin(identification: Identification, config, weights_path: Path,
                  say: Callable[[str], None], spread: dict | None = None, deadline: float = math.inf) -> AgentRun:
    """(c): the starting policy trained further on the identified twin (laptop time, its last episode starting
    before `deadline`, a `time.time()`); with `spread` ({field: (low, high)}:
    `pendkit.adapt.uncertainty.fit_spread`) on a rig drawn from it every episode."""
    from pendkit.agents.train import train_sync

    in_time = lambda *_: time.time() < deadline  # noqa: E731

    spec, state = starting_weights(config.policy)
    spec = dataclasses.replace(spec, randomize="", seed=config.seed)
    observer = policy_observer(spec, identification)
    env = twin_env(spec, identification, observer, spread, config.seed)
    _, agent, inputs = build_run(spec, env)
    if state is not None:
        agent.load_state_dict(state)
        returns = train_sync(env, agent, config.twin_episodes, inputs, seed=config.seed, progress=False,
                             on_episode=in_time) if config.twin_episodes else []
    else:  # afresh: until the kit's rule holds on the identified twin, as any training from nothing stops
        from pendkit.agents.policy_rule import train_until_solved

        probe = twin_env(spec, identification, observer, None, config.seed)
        returns, _ = train_until_solved(env, agent, inputs, config.twin_episodes, probe=probe, seed=config.seed,
                                        progress=False, max_wall_s=max(0.0, deadline - time.time()))
    save_weights(weights_path, agent, spec, {"identified_rig": identification.values(), "twin_episodes": len(returns)})
    drawn = " (a rig drawn from what the recordings allow each episode)" if spread else ""
    say(f"(c) {config.policy if state is not None else spec.learner + ' (afresh)'} trained "
        f"{len(returns)} episodes on the identified twin{drawn}")
    return AgentRun(spec, agent, inputs, observer)


def run_of_row(row: dict, identification: Identification, config) -> AgentRun:
    """The `AgentRun` of a candidate's verdict row (its spec, observer and weights)."""
    env = twin_env(row["spec"], identification, row["observer"], None, config.seed)
    _, agent, inputs = build_run(row["spec"], env)
    agent.load_state_dict(row["state"])
    env.close()
    return AgentRun(row["spec"], agent, inputs, row["observer"])


def held_on_device(identification: Identification, spec: RunSpec, agent, inputs, observer, seed: int,
                   need: int = 0) -> int | None:
    """Of the kit's rule's 10 starts, how many hold with the policy run by the identified rig's own device (its
    blob as `policy_on_device` makes it; no network between the readings and the targets, what the device's
    route meets); None for a learner the device does not run. Stops as soon as fewer than `need` can hold."""
    from pendkit.agents.policy_rule import RULE_STARTS

    if spec.learner not in DEVICE_LEARNERS:
        return None
    device = identified_twin(dataclasses.replace(identification, network=NetworkImpairment()),
                             action_mode="continuous")
    upload_to_twin(device, device_blob(AgentRun(spec, agent, inputs, observer), identification))
    held = 0
    for k, start in enumerate(RULE_STARTS):
        held += holds_upright(onboard_episode(device, seed=seed + k, start=start, steps=EPISODE_STEPS),
                              SOLVED_TAIL_STEPS)
        if held + len(RULE_STARTS) - k - 1 < need:
            break
    device.close()
    return held


def device_blob(run: AgentRun, identification: Identification) -> bytes:
    """`run`'s policy as the rig's device runs it (`pendkit.deploy.learned_blob`): its observers designed as on
    the way to the rig, a single one on the delays of the identified twin it was trained on."""

    twin = identified_twin(identification, **run.env_kwargs())
    return pack(learned_policy_blob(run.spec, None, identification.params, run.observer_params, twin.unwrapped.timing,
                                    run=(twin, run.agent, run.inputs)))


def policy_observer(spec: RunSpec, identification: Identification) -> RigParams | tuple[RigParams, ...]:
    """The rig a learned policy's observer is designed for on the way to the rig: the identified one for a
    policy trained with observers told each rig (`spec.observer == "rig"`); for `"bank"` the bank it was
    trained with, the identified rig joining it as its first candidate (shown until the readings rank
    them); else the nominal rig it was trained with (a recurrent policy that reads the nominal observer's
    errors to tell the rig)."""
    if spec.observer == "bank":
        return (identification.params, *observer_bank())
    return identification.params if spec.observer == "rig" else RigParams()


def fine_tune_on_rig(rig, run: AgentRun, episodes: int, config, weights_path: Path,
                     say: Callable[[str], None]) -> None:
    """(d): the episodes left on the rig, acting greedily-ish while the non-blocking trainer learns."""
    if episodes <= 0:
        return

    env = run.make_env(rig)
    trainer = AsyncTrainer(run.agent, [env], [run.inputs], seed=config.seed)
    stats = trainer.run(seconds=episodes * 60.0, episodes=episodes)
    env.close()
    save_weights(weights_path, run.agent, run.spec, {"rig_episodes": len(stats.episodes[0])})
    say(f"(d) {len(stats.episodes[0])} episodes on the rig, {stats.learner_updates} learner updates")


CLASSICAL = tuple(c.name for c in adapt_controllers())  # what adapt designs for the identified rig


def classical_on_env(design_env, env, controller: str, episodes: int, seed: int = 10_000,
                     start: str | None = None) -> Evaluation:
    """A classical controller designed on `design_env` (a twin) run greedy on `env` (a rig, or another
    twin), both continuous and unfiltered; judged by the kit's "solved" rule."""
    return judge_runs(env, controller_named(controller).host(design_env), [start] * episodes, seed)


def classical_on_device(rig, identification: Identification, episodes: int, tried=None, made=None) -> dict:
    """The same two designs for the rig's own device (`pendkit.deploy.swingup_design`, on the identified
    parameters), and the design the device trials chose (`tried`, a `pendkit.adapt.trials.Design`) if any,
    uploaded and run there from rest: the network carries heartbeats and telemetry only. `made`: one of the
    two already made (an untried `Design` on the identified parameters), not designed again."""
    if episodes == 0 or rig.run_on_device is None:
        return {name: {"summary": "not evaluated"} for name in CLASSICAL}

    step_s = identification.params.control_step_ms / 1000

    def blob(name: str) -> bytes:
        if made is not None and made.controller == name and made.params == identification.params:
            return made.blob
        return pack(design_swing_up(identification.params, name))

    blobs = {name: blob(name) for name in CLASSICAL}
    if tried is not None:
        blobs["tried"] = tried.blob
    return {name: _as_report(judged(rig.run_on_device(blob, episodes), step_s)) for name, blob in blobs.items()}


def judged(runs: list[list[float]], step_s: float) -> Evaluation:
    """Episodes run by a rig's device (each its angles from upright) judged as the laptop's are."""
    return judged_episodes(runs, step_s)


def policy_on_device(rig, run: AgentRun | None, identification: Identification, episodes: int,
                     blob_path: Path | None = None) -> dict:
    """The adapted policy as the rig's device runs it (`pendkit.deploy.learned_blob`: its observers designed as
    on the way to the rig, on the identified twin's delays for a single one, the device's for a bank),
    uploaded and run from rest as the classical designs are there; written to `blob_path` for `pendkit deploy
    --blob`. Not evaluated for a learner the device does not run."""

    if episodes == 0 or rig.run_on_device is None or run is None or run.spec.learner not in DEVICE_LEARNERS:
        return {"summary": "not evaluated"}
    blob = device_blob(run, identification)
    if blob_path is not None:
        write_bytes(blob_path, blob)
    return _as_report(judged(rig.run_on_device(blob, episodes), identification.params.control_step_ms / 1000))


def classical_on_rig(rig, identification: Identification, episodes: int) -> dict:
    """Energy swing-up + LQR and the minimum-time swing-up, designed on the identified twin, run on the rig."""
    if episodes == 0:
        return {name: {"summary": "not evaluated"} for name in CLASSICAL}
    design = identified_twin(identification, action_mode="continuous", filter_coefficient=0.0)
    env = rig.make_env(action_mode="continuous", filter_coefficient=0.0)
    outcomes = {name: _as_report(classical_on_env(design, env, name, episodes)) for name in CLASSICAL}
    env.close()
    design.close()
    return outcomes
