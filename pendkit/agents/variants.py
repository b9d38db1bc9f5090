"""The learners the kit names, each an algorithm plus what it sees: one place for the CLI, the benchmark
and the labs.

| name              | agent                   | input each step                                         |
|-------------------|-------------------------|---------------------------------------------------------|
| dqn               | DQN                     | observation + last action                               |
| dqn+actions       | DQN                     | observation + the actions it has not seen (delay-aware) |
| dqn+estimated     | DQN                     | the observer's estimate of the present state + action   |
| r-dqn             | R-DQN, trained GRU      | observation + last action, through the GRU              |
| r-dqn-reservoir   | DQN on a fixed GRU      | the ablation: an untrained random GRU's encoding        |
| td3, td3+actions, td3+estimated, r-td3, r-td3-reservoir: the same for TD3's continuous actions |
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from pendkit.agents.inputs import StepInputs, actions_for_delay
from pendkit.errors import ConfigError

BASES = ("dqn", "r-dqn", "r-dqn-reservoir", "td3", "r-td3", "r-td3-reservoir")
FRONT_ENDS = ("", "+actions", "+estimated")
VARIANT_NAMES = tuple(base + front for base in ("dqn", "td3") for front in FRONT_ENDS) + (
    "r-dqn", "r-dqn-reservoir", "r-td3", "r-td3-reservoir")
RESERVOIR_SIZE = 32


@dataclass(frozen=True)
class Variant:
    """`base` algorithm; `actions_seen` (an int, or "delay": from the env's delay); `features` of the env."""

    name: str
    base: str
    actions_seen: int | str = 1
    features: str = "measured"

    @property
    def continuous(self) -> bool:
        return "td3" in self.base

    @property
    def action_mode(self) -> str:
        return "continuous" if self.continuous else "discrete"

    def env_kwargs(self) -> dict:
        """What `pendkit.make` needs for this variant (beyond the fidelity)."""
        return {"action_mode": self.action_mode, "features": self.features}


def variant(name: str) -> Variant:
    if name not in VARIANT_NAMES:
        raise ConfigError(f"unknown learner {name!r}; choose from {', '.join(VARIANT_NAMES)}")
    base, _, front = name.partition("+")
    v = Variant(name, base)
    if front == "actions":
        v = replace(v, actions_seen="delay")
    elif front == "estimated":
        v = replace(v, features="estimated")
    return v


def env_delay_s(env) -> float:
    """Age of what the agent sees, in seconds: whole-step observation delays (wrappers with `delay_steps`)
    plus the backend's expected command and reading delays."""
    from pendkit.control.lqr import expected_delays_s

    delay, layer = 0.0, env
    while hasattr(layer, "env"):
        delay += getattr(layer, "delay_steps", 0) * env.unwrapped.dt
        layer = layer.env
    base = env.unwrapped
    actuation_s, reading_s = expected_delays_s(base) if hasattr(base.backend, "timing") else (0.0, 0.0)
    return delay + actuation_s + reading_s


def inputs_for(v: Variant, env, seed: int = 0) -> StepInputs:
    seen = actions_for_delay(env_delay_s(env), env.unwrapped.dt) if v.actions_seen == "delay" else v.actions_seen
    encoder = None
    if v.base.endswith("-reservoir"):
        from pendkit.agents.gru_encoder import GruEncoder

        step = StepInputs.for_env(env, seen).step_dim
        encoder = GruEncoder(step, RESERVOIR_SIZE, seed)
    return StepInputs.for_env(env, seen, encoder)


def build_learner(name: str, env, seed: int = 0, **config) -> tuple[object, StepInputs]:
    """(agent, inputs) for a named learner on `env`; `config` overrides the agent's config fields."""
    v = variant(name)
    if env.unwrapped.action_mode != v.action_mode:
        raise ConfigError(f"{name} needs action_mode={v.action_mode!r}, the env has {env.unwrapped.action_mode!r}")
    inputs = inputs_for(v, env, seed)
    if v.base in ("dqn", "r-dqn-reservoir"):
        from pendkit.agents.dqn import DqnAgent, DqnConfig

        return DqnAgent(inputs.dim, env.action_space.n, DqnConfig(seed=seed, **config)), inputs
    if v.base == "r-dqn":
        from pendkit.agents.recurrent_dqn import RecurrentDqnAgent, RecurrentDqnConfig

        return RecurrentDqnAgent(inputs.dim, env.action_space.n, RecurrentDqnConfig(seed=seed, **config)), inputs
    action_dim = math.prod(env.action_space.shape)
    if v.base in ("td3", "r-td3-reservoir"):
        from pendkit.agents.td3 import Td3Agent, Td3Config

        return Td3Agent(inputs.dim, action_dim, Td3Config(seed=seed, **config)), inputs
    from pendkit.agents.recurrent_td3 import RecurrentTd3Agent, RecurrentTd3Config

    return RecurrentTd3Agent(inputs.dim, action_dim, RecurrentTd3Config(seed=seed, **config)), inputs
