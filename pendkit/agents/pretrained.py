"""Policies trained on the twin and shipped with the kit, weights only (lab 09 deploys them to a rig).

    python -m pendkit.agents.pretrained          # trains them again into pendkit/data/policies (~6 min)

| name            | learner | trained on                | episodes |
|-----------------|---------|---------------------------|----------|
| dqn-ideal       | dqn     | the ideal twin            | 120      |
| r-dqn-realistic | r-dqn   | the realistic twin        | 260      |
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pendkit.errors import ConfigError

POLICY_DIR = Path(__file__).resolve().parents[1] / "data" / "policies"


@dataclass(frozen=True)
class PretrainedSpec:
    algo: str
    fidelity: str
    episodes: int
    seed: int = 0


POLICIES = {"dqn-ideal": PretrainedSpec("dqn", "ideal", 120),
            "r-dqn-realistic": PretrainedSpec("r-dqn", "realistic", 260)}


class GreedyPolicy:
    """A trained agent as `policy(observation, state) -> action`, fed what it saw in training."""

    def __init__(self, agent, inputs) -> None:
        self.agent, self.inputs = agent, inputs
        self._x, self._last = None, None

    def reset(self, state=None) -> None:
        self._x, self._last = None, None
        if getattr(self.agent, "recurrent", False):
            self.agent.reset()

    def __call__(self, observation, state=None):
        self._x = self.inputs.reset(observation) if self._x is None else self.inputs.step(observation, self._last)
        self._last = self.agent.act(self._x, explore=False)
        return self._last


def load_policy(name: str, env) -> GreedyPolicy:
    """The shipped policy `name` for `env` (a discrete-action env: twin or rig)."""
    import torch

    from pendkit.agents.variants import build_learner

    if name not in POLICIES:
        raise ConfigError(f"unknown policy {name!r}; the kit ships {sorted(POLICIES)}")
    path = POLICY_DIR / f"{name}.pt"
    if not path.exists():
        raise ConfigError(f"{path} is missing: run `python -m pendkit.agents.pretrained` to train it")
    spec = POLICIES[name]
    agent, inputs = build_learner(spec.algo, env, spec.seed)
    agent.load_state_dict(torch.load(path, weights_only=False))
    return GreedyPolicy(agent, inputs)


def build(names: list[str] | None = None) -> None:
    """Train the named policies (all by default) and write their weights."""
    import torch

    import pendkit
    from pendkit.agents.train import train_sync
    from pendkit.agents.variants import build_learner, variant

    POLICY_DIR.mkdir(parents=True, exist_ok=True)
    for name in names or list(POLICIES):
        spec = POLICIES[name]
        env = pendkit.make(fidelity=spec.fidelity, **variant(spec.algo).env_kwargs())
        agent, inputs = build_learner(spec.algo, env, spec.seed)
        returns = train_sync(env, agent, spec.episodes, inputs, seed=spec.seed)
        torch.save(agent.state_dict(), POLICY_DIR / f"{name}.pt")
        print(f"{name}: last 10 mean return {sum(returns[-10:]) / 10:.1f}")


if __name__ == "__main__":
    build()
