"""Policies trained on the twin and shipped with the kit, in the kit's weights format (lab 09 deploys them).

    pendkit policies build [NAME ...]      # trains them again into pendkit/data/policies (~6 min)
    python -m pendkit.agents.pretrained    # the same

| name            | learner | trained on                | episodes |
|-----------------|---------|---------------------------|----------|
| dqn-ideal       | dqn     | the ideal twin            | 120      |
| r-dqn-realistic | r-dqn   | the realistic twin        | 260      |
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from pendkit.agents.runs import RunSpec, build_run, load_weights, save_weights
from pendkit.errors import ConfigError

POLICY_DIR = Path(__file__).resolve().parents[1] / "data" / "policies"


@dataclass(frozen=True)
class PretrainedSpec:
    run: RunSpec
    episodes: int


POLICIES = {"dqn-ideal": PretrainedSpec(RunSpec("dqn", "ideal"), 120),
            "r-dqn-realistic": PretrainedSpec(RunSpec("r-dqn", "realistic"), 260)}


class GreedyPolicy:
    """A trained agent as `policy(observation, state) -> action`, fed what it saw in training."""

    def __init__(self, agent, inputs) -> None:
        self.agent, self.inputs = agent, inputs
        self._x, self._last = None, None

    def reset(self, state=None) -> None:
        self._x, self._last = None, None
        self.agent.reset()

    def __call__(self, observation, state=None):
        self._x = self.inputs.reset(observation) if self._x is None else self.inputs.step(observation, self._last)
        self._last = self.agent.act(self._x, explore=False)
        return self._last


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
    _, agent, inputs = build_run(spec, env)
    agent.load_state_dict(state)
    return GreedyPolicy(agent, inputs)


def build(names: list[str] | None = None) -> None:
    """Train the named policies (all by default) and write their weights."""
    from pendkit.agents.train import train_sync

    POLICY_DIR.mkdir(parents=True, exist_ok=True)
    for name in names or list(POLICIES):
        if name not in POLICIES:
            raise ConfigError(f"unknown policy {name!r}; the kit ships {sorted(POLICIES)}")
        spec = POLICIES[name]
        env, agent, inputs = build_run(spec.run)
        returns = train_sync(env, agent, spec.episodes, inputs, seed=spec.run.seed)
        save_weights(POLICY_DIR / f"{name}.pt", agent, spec.run, {"episodes": spec.episodes})
        print(f"{name}: last 10 mean return {sum(returns[-10:]) / 10:.1f}")


if __name__ == "__main__":
    build(sys.argv[1:] or None)
