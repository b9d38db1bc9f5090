"""Policies trained on the twin and shipped with the kit, in the kit's weights format (lab 09 deploys them).

    pendkit policies build [NAME ...]      # trains them again into pendkit/data/policies (~25 min of one core)
    python -m pendkit.agents.pretrained    # the same

| name            | learner | trained on                | episodes |
|-----------------|---------|---------------------------|----------|
| dqn-ideal       | dqn     | the ideal twin            | 300 (kept by the rule) |
| r-dqn-realistic | r-dqn   | the realistic twin        | 260      |
| r-dqn-levels-realistic | r-dqn+levels | the realistic twin | 800 (kept by the rule) |
| td3-realistic   | td3+estimated | the realistic twin  | 300      |
| td3-robust      | td3+estimated | a new realistic rig each episode, observer told the rig | 1000 (~25 min) |
| r-td3-robust    | r-td3+both    | a new realistic rig each episode, the nominal observer  | 1000 (~40 min) |
| r-td3-bank-robust | r-td3+both  | a new realistic rig each episode, a bank of observers   | 600 (~50 min)  |
| r-dqn-robust    | r-dqn   | a new realistic rig each episode | 1500 (~55 min) |

r-dqn-robust (`randomize="robust"`) keeps the checkpoint that did best on rigs drawn from its training
ranges, not its last one: over so many rigs R-DQN peaks and unlearns (docs/results/transfer.md).
"""

from __future__ import annotations

import copy
import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path

from pendkit.agents.learners import learner
from pendkit.agents.rig_suite import policy_on_rigs, summary, unknown_rig_observer, validation_rigs
from pendkit.agents.runs import RunSpec, build_run, load_weights, save_weights
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.sim.randomize import RandomRig

# pendkit modules that load torch are imported inside the functions that use them: importing this module does not need
# them (start-up; torch is an optional extra).

POLICY_DIR = Path(__file__).resolve().parents[1] / "data" / "policies"
MEASURED_FILE = POLICY_DIR / "measured.json"  # written by benchmarks/bench_policies.py --record

KEPT_BY = ("rigs", "rigs+default", "rule")
DEFAULT_RIG_CHECK_STARTS, DEFAULT_RIG_CHECK_SEED = 3, 20_000  # seeds apart from the default rig's judging ones


@dataclass(frozen=True)
class PretrainedSpec:
    """`check_every` > 0: after each such stretch the greedy agent is scored and the best checkpoint is kept,
    not the last. `kept_by="rigs"`: on `validation_rigs` rigs drawn from the training ranges
    (`rig_suite.validation_rigs`); `"rigs+default"`: those and the default rig (rest + 3 random starts), so
    that a checkpoint which loses the rig most users have is not kept; `"rule"`: by the kit's rule on its
    training starts (episodes held, then mean return; `pendkit.agents.policy_rule`)."""

    run: RunSpec
    episodes: int
    check_every: int = 0
    validation_rigs: int = 8
    built_by_default: bool = True  # False: only when named (an hour's training)
    kept_by: str = "rigs"
    role: str = ""  # what the policy is kept for, said beside its figures (those below the shipped bar say why)

    def __post_init__(self) -> None:
        if self.kept_by not in KEPT_BY:
            raise ConfigError(f"kept_by must be one of {', '.join(KEPT_BY)}, got {self.kept_by!r}")


# the larger network and buffer: over rigs that change every episode the default R-DQN plateaus
# (docs/results/transfer.md)
ROBUST_AGENT = {"hidden": [128, 128], "gru_size": 64, "sequence_length": 16, "learning_rate": 5e-4,
                "buffer_capacity": 1_000_000}
POLICIES = {"dqn-ideal": PretrainedSpec(RunSpec("dqn", "ideal"), 300, check_every=20, kept_by="rule"),
            "r-dqn-realistic": PretrainedSpec(RunSpec("r-dqn", "realistic"), 260, role=(
                "the device's policy blobs (five ramps) and their shared vectors; with the ramps R-DQN on the raw "
                "readings did not reach the rule in 3 seeds up to 2000 episodes, r-dqn-levels-realistic does "
                "(docs/results/learning.md)")),
            # continuous, through the c = 0.85 filter, reading the observer's estimate of the present state
            # (plain TD3 and R-TD3 on the raw readings spin the pendulum round instead: docs/results/learning.md)
            # R-DQN choosing between 9 targets through the filter, not the five ramps: on the same raw readings it
            # holds where r-dqn-realistic does not (docs/results/learning.md)
            "r-dqn-levels-realistic": PretrainedSpec(RunSpec("r-dqn+levels", "realistic", seed=1), 800,
                                                     check_every=50, kept_by="rule"),
            "td3-realistic": PretrainedSpec(RunSpec("td3+estimated", "realistic", seed=1), 300, check_every=20,
                                            kept_by="rule"),
            # over the robust ranges, its observer designed for each drawn rig: the start `pendkit adapt`
            # gives an observer designed for the identified rig (zero-shot, with the nominal rig's
            # observer, it does not hold: docs/results/robust.md)
            "td3-robust": PretrainedSpec(RunSpec("td3+estimated", "realistic", randomize="robust", observer="rig"),
                                         1000, check_every=100, built_by_default=False, role=(
                                             "a start for pendkit adapt --policy td3-robust: it holds when its "
                                             "observer is told the rig, not with the nominal one "
                                             "(docs/results/robust.md)")),
            # zero-shot over the robust ranges: a GRU reading the nominal observer's estimate and the raw readings,
            # which shows it where the observer's model and the rig part (docs/results/robust.md)
            "r-td3-robust": PretrainedSpec(RunSpec("r-td3+both", "realistic", randomize="robust"), 1000,
                                           check_every=100, built_by_default=False),
            # the same learner with a bank of observers in training and on every rig (nothing told): it holds more
            # unseen rigs than r-td3-robust (docs/results/robust.md)
            "r-td3-bank-robust": PretrainedSpec(RunSpec("r-td3+both", "realistic", seed=1, randomize="robust",
                                                        observer="bank"), 600, check_every=100,
                                                built_by_default=False, kept_by="rigs+default"),
            "r-dqn-robust": PretrainedSpec(RunSpec("r-dqn", "realistic", randomize="robust", agent=ROBUST_AGENT),
                                           1500, check_every=125, built_by_default=False, role=(
                                               "the discrete policy over many rigs, for comparison "
                                               "(docs/results/transfer.md); r-td3-robust holds the default rig"))}


class GreedyPolicy:
    """A trained agent as `policy(observation, state) -> action`, fed what it saw in training; `to_env_action`
    turns the agent's action into the env's (a target level into its target)."""

    def __init__(self, agent, inputs, to_env_action=None) -> None:
        self.agent, self.inputs, self.to_env_action = agent, inputs, to_env_action
        self._x, self._last = None, None

    def reset(self, state=None) -> None:
        self._x, self._last = None, None
        self.agent.reset()

    def __call__(self, observation, state=None):
        self._x = self.inputs.reset(observation) if self._x is None else self.inputs.step(observation, self._last)
        self._last = self.agent.act(self._x, explore=False)
        return self._last if self.to_env_action is None else self.to_env_action(self._last)


def weights_digest(name: str) -> str:
    """SHA-256 of a shipped policy's weights file: measured figures name the weights they were measured on."""
    import hashlib

    return hashlib.sha256((POLICY_DIR / f"{name}.pt").read_bytes()).hexdigest()


def policy_env_options(name: str) -> dict:
    """What `pendkit.make` needs for shipped policy `name` on its own twin or a rig: its fidelity (twin
    only), action mode and features, e.g. `pendkit.make(**policy_env_options(name), start="rest")`; a policy
    trained with observers told each rig meets the rig with the observer bank
    (`pendkit.sim.randomize.observer_bank`)."""

    if name not in POLICIES:
        raise ConfigError(f"unknown policy {name!r}; the kit ships {sorted(POLICIES)}")
    run = POLICIES[name].run
    return {"fidelity": run.fidelity, **learner(run.learner).env_kwargs(), **unknown_rig_observer(run)}


def measured_figures() -> tuple[dict, str]:
    """({policy: {condition: figures}}, the command that measured them) from MEASURED_FILE ({} if absent)."""
    import json

    if not MEASURED_FILE.exists():
        return {}, ""
    try:
        record = json.loads(MEASURED_FILE.read_text())
        return dict(record["policies"]), str(record["command"])
    except (ValueError, KeyError, TypeError):
        return {}, ""


def policies_that_hold() -> list[str]:
    """The shipped policies whose recorded figures on their own twin reach the shipped bar
    (`pendkit.agents.policy_rule.SHIPPED_TEXT`); the others are kept for what their `role` says."""
    from pendkit.agents.policy_rule import meets_shipped_bar

    measured, _ = measured_figures()
    return [name for name in POLICIES if "twin" in measured.get(name, {}) and meets_shipped_bar(measured[name]["twin"])]


def policy_weights(name: str) -> tuple[RunSpec, dict]:
    """(spec, agent state) of the shipped policy `name`."""
    if name not in POLICIES:
        raise ConfigError(f"unknown policy {name!r}; the kit ships {sorted(POLICIES)}")
    path = POLICY_DIR / f"{name}.pt"
    if not path.exists():
        raise ConfigError(f"{path} is missing: run `pendkit policies build {name}` to train it")
    return load_weights(path)


def load_policy(name: str, env) -> GreedyPolicy:
    """The shipped policy `name` for `env` (an env of the policy's action mode: twin or rig)."""

    spec, state = policy_weights(name)
    chosen = learner(spec.learner)
    acting = chosen.wrap(env) if chosen.target_levels and not hasattr(env.action_space, "n") else env
    _, agent, inputs = build_run(spec, acting)
    agent.load_state_dict(state)
    return GreedyPolicy(agent, inputs, acting.action if acting is not env else None)


def build(names: list[str] | None = None) -> None:
    """Train the named policies (by default those built in minutes) and write their weights."""
    from pendkit.agents.train import train_sync

    POLICY_DIR.mkdir(parents=True, exist_ok=True)
    for name in names or [name for name, spec in POLICIES.items() if spec.built_by_default]:
        if name not in POLICIES:
            raise ConfigError(f"unknown policy {name!r}; the kit ships {sorted(POLICIES)}")
        spec = POLICIES[name]
        env, agent, inputs = build_run(spec.run)
        notes = {"episodes": spec.episodes}
        if spec.check_every:
            score = {"rule": rule_score, "rigs": validation_score, "rigs+default": validation_and_default_score}[
                spec.kept_by]
            returns, chosen = train_keeping_best(env, agent, inputs, spec, score)
            notes.update(chosen)
        else:
            returns = train_sync(env, agent, spec.episodes, inputs, seed=spec.run.seed)
        # the weights' spec builds the agent on one rig; what it was trained over is in the notes
        notes["trained_on"] = spec.run.randomize or spec.run.fidelity
        save_weights(POLICY_DIR / f"{name}.pt", agent, dataclasses.replace(spec.run, randomize=""), notes)
        print(f"{name}: last 10 mean return {sum(returns[-10:]) / 10:.1f}; {notes}")


def validation_score(spec: PretrainedSpec, state: dict) -> tuple[int, float]:
    """(episodes solved, mean return) of the greedy agent on the validation rigs, from rest and one random
    start each: higher is better."""

    together = summary(policy_on_rigs(spec.run, state, validation_rigs(spec.validation_rigs), starts=1,
                                      observer_knows_rig=spec.run.observer == "rig"))
    return together["solved"], float(together["mean_return"])


def validation_and_default_score(spec: PretrainedSpec, state: dict, starts: int = DEFAULT_RIG_CHECK_STARTS,
                                 say=print) -> tuple[int, float]:
    """`validation_score` plus the episodes held on the default rig (rest + `starts` random starts): a
    validation that also sees the rig most users have. Each part is said."""

    solved, mean_return = validation_score(spec, state)
    default = policy_on_rigs(spec.run, state, {"default": RandomRig(RigParams(), None, 0)}, starts=starts,
                             seed=DEFAULT_RIG_CHECK_SEED)["default"]
    say(f"  validation rigs {solved}, default rig {sum(default.solved)}/{len(default.solved)}")
    return solved + sum(default.solved), mean_return


def rule_score(spec: PretrainedSpec, state: dict) -> tuple[int, float]:
    """(episodes held, mean return) of the greedy agent by the kit's rule on its training starts."""
    from pendkit.agents.policy_rule import JUDGE_SEED, judge_policy

    env, agent, inputs = build_run(spec.run)
    agent.load_state_dict(state)
    verdict = judge_policy(env, agent, inputs, JUDGE_SEED)
    env.close()
    return verdict.held, verdict.evaluation.mean_return


def train_keeping_best(env, agent, inputs, spec: PretrainedSpec, score=validation_score) -> tuple[list[float], dict]:
    """Train in stretches of `spec.check_every` episodes, `score(spec, state)` the agent after each and leave
    it at the best-scored state (the first of equals); returns (every return, which checkpoint was kept)."""
    from pendkit.agents.train import train_sync

    buffer = agent.new_buffer(spec.run.seed)
    returns, best = [], None
    while len(returns) < spec.episodes:
        stretch = min(spec.check_every, spec.episodes - len(returns))
        returns += train_sync(env, agent, stretch, inputs, buffer=buffer, seed=spec.run.seed * 7919 + len(returns))
        checked = score(spec, agent.state_dict())
        print(f"{len(returns)} episodes: validation solved {checked[0]}, mean return {checked[1]:.0f}")
        if best is None or checked > best[0]:
            best = (checked, len(returns), copy.deepcopy(agent.state_dict()))
    agent.load_state_dict(best[2])
    return returns, {"chosen_at_episode": best[1], "validation_solved": best[0][0],
                     "validation_mean_return": round(best[0][1], 1)}


if __name__ == "__main__":
    build(sys.argv[1:] or None)
