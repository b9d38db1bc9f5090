"""The learner registry: each learner the kit names is an algorithm plus what it sees, in one table
(`LEARNERS`) that the CLI, the shipped policies, the benchmarks and the labs read.

| name              | agent                   | input each step                                         |
|-------------------|-------------------------|---------------------------------------------------------|
| dqn               | DQN                     | observation + last action                               |
| dqn+actions       | DQN                     | observation + the actions it has not seen (delay-aware) |
| dqn+estimated     | DQN                     | the observer's estimate of the present state + action   |
| r-dqn             | R-DQN, trained GRU      | observation + last action, through the GRU              |
| r-dqn+estimated   | R-DQN, trained GRU      | the observer's estimate + last action, through the GRU  |
| r-td3+both        | R-TD3, trained GRU      | the estimate and the raw readings + last action (GRU)   |
| r-dqn-reservoir   | DQN on a fixed GRU      | the ablation: an untrained random GRU's encoding        |
| r-dqn+levels      | R-DQN, trained GRU      | as r-dqn; acts on 9 continuous targets, not the 5 ramps |
| td3, td3+actions, td3+estimated, td3+both, r-td3, r-td3-reservoir: the same for TD3's continuous actions |
| sac, sac+actions, sac+estimated: SAC (squashed Gaussian actor, tuned entropy) on the same inputs as TD3's |

r-dqn and r-td3+both also run on the rig's device (their rows' `device_layout`; `DEVICE_LEARNERS`).

A new agent is one module with a class that keeps the contract (`pendkit.agents.base.Agent`) and one
`Algorithm` row here; a new learner on an existing algorithm is one `Learner` row.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from pendkit.agents.base import Agent
from pendkit.agents.inputs import StepInputs, actions_for_delay
from pendkit.agents.spec_checks import check_agent_types, check_agent_values
from pendkit.agents.target_levels import TargetLevels
from pendkit.errors import ConfigError

# pendkit modules that load torch are imported inside the functions that use them: importing this module does not need
# them (start-up; torch is an optional extra).

RESERVOIR_SIZE = 32
TARGET_LEVELS = 9  # 22.5 deg apart, smoothed by the c = 0.85 filter


def _dqn(input_dim: int, env, seed: int, config: dict) -> Agent:
    from pendkit.agents.dqn import DqnAgent, DqnConfig

    return DqnAgent(input_dim, env.action_space.n, DqnConfig(seed=seed, **config))


def _r_dqn(input_dim: int, env, seed: int, config: dict) -> Agent:
    from pendkit.agents.recurrent_dqn import RecurrentDqnAgent, RecurrentDqnConfig

    return RecurrentDqnAgent(input_dim, env.action_space.n, RecurrentDqnConfig(seed=seed, **config))


def _td3(input_dim: int, env, seed: int, config: dict) -> Agent:
    from pendkit.agents.td3 import Td3Agent, Td3Config

    return Td3Agent(input_dim, math.prod(env.action_space.shape), Td3Config(seed=seed, **config))


def _sac(input_dim: int, env, seed: int, config: dict) -> Agent:
    from pendkit.agents.sac import SacAgent, SacConfig

    return SacAgent(input_dim, math.prod(env.action_space.shape), SacConfig(seed=seed, **config))


def _r_td3(input_dim: int, env, seed: int, config: dict) -> Agent:
    from pendkit.agents.recurrent_td3 import RecurrentTd3Agent, RecurrentTd3Config

    return RecurrentTd3Agent(input_dim, math.prod(env.action_space.shape), RecurrentTd3Config(seed=seed, **config))


@dataclass(frozen=True)
class Algorithm:
    """How to make the agent (`make(input_dim, env, seed, config overrides)`), which action mode it needs,
    whether its inputs pass through a fixed random GRU first (the reservoir ablation), and its config class
    ("module:Class", for checking settings before anything runs)."""

    make: Callable[[int, object, int, dict], Agent]
    continuous: bool
    config: str
    reservoir: bool = False


ALGORITHMS: dict[str, Algorithm] = {
    "dqn": Algorithm(_dqn, continuous=False, config="pendkit.agents.dqn:DqnConfig"),
    "r-dqn": Algorithm(_r_dqn, continuous=False, config="pendkit.agents.recurrent_dqn:RecurrentDqnConfig"),
    "r-dqn-reservoir": Algorithm(_dqn, continuous=False, config="pendkit.agents.dqn:DqnConfig", reservoir=True),
    "td3": Algorithm(_td3, continuous=True, config="pendkit.agents.td3:Td3Config"),
    "r-td3": Algorithm(_r_td3, continuous=True, config="pendkit.agents.recurrent_td3:RecurrentTd3Config"),
    "r-td3-reservoir": Algorithm(_td3, continuous=True, config="pendkit.agents.td3:Td3Config", reservoir=True),
    "sac": Algorithm(_sac, continuous=True, config="pendkit.agents.sac:SacConfig"),
}


def check_agent_settings(name: str, settings: dict) -> None:
    """Refuse, by name, a setting learner `name`'s agent does not have or a value it does not take."""
    import dataclasses
    import importlib

    module, _, cls = ALGORITHMS[learner(name).algorithm].config.partition(":")
    config_class = getattr(importlib.import_module(module), cls)
    known = {f.name for f in dataclasses.fields(config_class)} - {"seed"}
    unknown = sorted(set(settings) - known)
    if unknown:
        raise ConfigError(f"agent: {', '.join(map(str, unknown))} is not a setting of {name}; its settings: "
                          f"{', '.join(sorted(known))}")

    check_agent_values(settings)  # sizes in their bounds
    check_agent_types(config_class, settings)
    try:
        config_class(**settings)
    except (TypeError, ValueError) as error:
        raise ConfigError(f"agent: {error}") from None


@dataclass(frozen=True)
class Learner:
    """`algorithm` (a key of ALGORITHMS); `actions_seen` (an int, or "delay": from the env's delay);
    `features` of the env ("measured"; "estimated": the observer's present state; "estimated+measured": both);
    `target_levels` (a discrete algorithm): that many continuous targets in place of the five ramps
    (`pendkit.agents.target_levels`); `device_layout`: the input layout of the policy blob the rig's device
    runs it as (`pendkit.device.policy_blob`: 1, the paper's readings; 2, its observers' estimate beside the
    readings), its agent providing the network (`device_network()`); 0, the device does not run it."""

    name: str
    algorithm: str
    actions_seen: int | str = 1
    features: str = "measured"
    target_levels: int = 0
    device_layout: int = 0

    @property
    def continuous(self) -> bool:
        return ALGORITHMS[self.algorithm].continuous

    @property
    def action_mode(self) -> str:
        return "continuous" if self.continuous or self.target_levels else "discrete"

    def wrap(self, env):
        """`env` (made with `env_kwargs`) as this learner acts on it."""
        if not self.target_levels:
            return env

        return TargetLevels(env, self.target_levels)

    def env_kwargs(self) -> dict:
        """What `pendkit.make` needs for this learner (beyond the fidelity)."""
        return {"action_mode": self.action_mode, "features": self.features}


def _family(algorithm: str) -> list[Learner]:
    return [Learner(algorithm, algorithm), Learner(f"{algorithm}+actions", algorithm, actions_seen="delay"),
            Learner(f"{algorithm}+estimated", algorithm, features="estimated")]


LEARNERS: dict[str, Learner] = {learner.name: learner for learner in [
    *_family("dqn"), Learner("r-dqn", "r-dqn", device_layout=1),
    Learner("r-dqn+estimated", "r-dqn", features="estimated"), Learner("r-dqn-reservoir", "r-dqn-reservoir"),
    Learner("r-dqn+levels", "r-dqn", target_levels=TARGET_LEVELS),
    *_family("td3"), Learner("td3+both", "td3", features="estimated+measured"), Learner("r-td3", "r-td3"),
    Learner("r-td3+both", "r-td3", features="estimated+measured", device_layout=2),
    Learner("r-td3-reservoir", "r-td3-reservoir"),
    *_family("sac"),
]}
LEARNER_NAMES = tuple(LEARNERS)
DEVICE_LEARNERS: dict[str, int] = {name: row.device_layout for name, row in LEARNERS.items() if row.device_layout}


def learner(name: str) -> Learner:
    if name not in LEARNERS:
        raise ConfigError(f"unknown learner {name!r}; choose from {', '.join(LEARNER_NAMES)}")
    return LEARNERS[name]


def env_delay_s(env) -> float:
    """Age of what the agent sees, in seconds: whole-step observation delays (wrappers with `delay_steps`)
    plus the backend's own command and reading delays (`BackendTiming`)."""
    delay, layer = 0.0, env
    while hasattr(layer, "env"):
        delay += getattr(layer, "delay_steps", 0) * env.unwrapped.dt
        layer = layer.env
    return delay + env.unwrapped.timing.loop_delay_s


def inputs_for(name: str, env, seed: int = 0) -> StepInputs:
    """What learner `name` sees on `env`, each step."""
    chosen = learner(name)
    seen = (actions_for_delay(env_delay_s(env), env.unwrapped.dt) if chosen.actions_seen == "delay"
            else chosen.actions_seen)
    encoder = None
    if ALGORITHMS[chosen.algorithm].reservoir:
        from pendkit.agents.gru_encoder import GruEncoder

        encoder = GruEncoder(StepInputs.for_env(env, seen).step_dim, RESERVOIR_SIZE, seed)
    return StepInputs.for_env(env, seen, encoder)


def build_learner(name: str, env, seed: int = 0, **config) -> tuple[Agent, StepInputs]:
    """(agent, inputs) for learner `name` on `env`; `config` overrides the agent's config fields."""
    chosen = learner(name)
    if env.unwrapped.action_mode != chosen.action_mode:
        raise ConfigError(f"{name} needs action_mode={chosen.action_mode!r}, the env has "
                          f"{env.unwrapped.action_mode!r}")
    source = getattr(env.unwrapped, "feature_source", "measured")
    if source != chosen.features:
        raise ConfigError(f"{name} reads features={chosen.features!r}, the env has features={source!r}: make it "
                          f"with pendkit.make(..., **learner({name!r}).env_kwargs())")
    if chosen.target_levels and not hasattr(env.action_space, "n"):
        raise ConfigError(f"{name} chooses between {chosen.target_levels} targets: wrap the env with "
                          f"learner({name!r}).wrap(env)")
    inputs = inputs_for(name, env, seed)
    return ALGORITHMS[chosen.algorithm].make(inputs.dim, env, seed, config), inputs
