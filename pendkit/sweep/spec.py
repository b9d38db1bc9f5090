"""A sweep's spec file (YAML or TOML) and the trials it expands to: learners x settings x seeds.

```yaml
name: delay-sweep
learners: [dqn, dqn+actions, r-dqn]
delay_steps: [0, 1, 2, 3]        # settings: any of fidelities, delay_steps, delay_ms, rigs (one list or several)
seeds: 3                         # 3 means seeds 0, 1, 2; or a list [0, 5, 7]
budget: {max_episodes: 300, max_wall_s: 400, check_every: 10}
randomize: ""                    # domain randomisation per episode (pendkit.sim.randomize), optional
agent: {}                        # overrides of the agents' settings, optional
```

A setting is one of: a fidelity preset's name (`fidelities`), the ideal twin seen `delay_steps` whole steps
late (`ObservationDelay`), the realistic pipeline with a fixed observation latency (`delay_ms`), or a rig's
parameter file as `RigParams.save` writes it, on the realistic twin (`rigs`, relative to the spec's folder).
"""

from __future__ import annotations

import dataclasses
import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path

from pendkit.errors import ConfigError

SETTING_KINDS = ("fidelities", "delay_steps", "delay_ms", "rigs")
KNOWN_KEYS = {"name", "learners", "seeds", "budget", "randomize", "agent", *SETTING_KINDS}


@dataclass(frozen=True)
class Budget:
    """How long a trial may learn, and how often its greedy policy is checked (episodes)."""

    max_episodes: int = 200
    max_wall_s: float = 600.0
    check_every: int = 10

    def __post_init__(self) -> None:
        if self.max_episodes < 1 or self.check_every < 1 or not self.max_wall_s > 0:
            raise ConfigError(f"a budget needs max_episodes >= 1, check_every >= 1 and max_wall_s > 0, got {self}")


@dataclass(frozen=True)
class Setting:
    """Where a trial learns: `kind` (one of SETTING_KINDS) and its value; `name` is what tables print."""

    kind: str
    value: str | int | float

    @property
    def name(self) -> str:
        if self.kind == "delay_steps":
            return f"ideal-delayed-{self.value}-steps"
        if self.kind == "delay_ms":
            return f"obs-delay-{self.value:g}ms"
        if self.kind == "rigs":
            return Path(str(self.value)).stem
        return str(self.value)


@dataclass(frozen=True)
class Trial:
    """One learning run of a sweep. `trial_id` names its folder and is stable across runs of the spec."""

    learner: str
    setting: Setting
    seed: int
    budget: Budget
    randomize: str = ""
    agent: dict = field(default_factory=dict)

    @property
    def trial_id(self) -> str:
        safe = "".join(c if c.isalnum() or c in "-._" else "_" for c in f"{self.learner}--{self.setting.name}")
        return f"{safe}--seed{self.seed}"

    def to_dict(self) -> dict:
        return dataclasses.asdict(self) | {"trial_id": self.trial_id, "setting_name": self.setting.name}

    @classmethod
    def from_dict(cls, record: dict) -> Trial:
        return cls(record["learner"], Setting(**record["setting"]), record["seed"], Budget(**record["budget"]),
                   record.get("randomize", ""), record.get("agent", {}))


@dataclass(frozen=True)
class SweepSpec:
    name: str
    trials: tuple[Trial, ...]
    source: dict

    @property
    def learners(self) -> list[str]:
        return list(dict.fromkeys(t.learner for t in self.trials))


def read_spec_file(path: str | Path) -> dict:
    """The spec's record from a .yaml/.yml or .toml file (JSON also serves)."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"no sweep spec at {path}")
    text = path.read_text()
    if path.suffix in (".yaml", ".yml"):
        try:
            import yaml
        except ImportError:
            raise ConfigError('a YAML spec needs PyYAML: pip install -e ".[cluster]" (or write the spec as '
                              "TOML)") from None
        record = yaml.safe_load(text)
    elif path.suffix == ".toml":
        import tomllib

        record = tomllib.loads(text)
    elif path.suffix == ".json":
        record = json.loads(text)
    else:
        raise ConfigError(f"{path}: a sweep spec is a .yaml, .toml or .json file")
    if not isinstance(record, dict):
        raise ConfigError(f"{path}: a sweep spec is a mapping of keys (name, learners, seeds, ...)")
    return record


def load_spec(path: str | Path, seeds: list[int] | None = None) -> SweepSpec:
    """The spec at `path`; `seeds` replaces its seeds (a student running only their own seed)."""
    path = Path(path)
    record = read_spec_file(path)
    if seeds:
        record = {**record, "seeds": list(seeds)}
    return parse_spec(record, path.parent)


def parse_spec(record: dict, folder: Path = Path(".")) -> SweepSpec:
    """The trials a spec's record names, in a stable order (setting, learner, seed), with clear errors."""
    from pendkit.agents.learners import learner

    unknown = sorted(set(record) - KNOWN_KEYS)
    if unknown:
        raise ConfigError(f"unknown keys in the sweep spec: {', '.join(unknown)}; "
                          f"known: {', '.join(sorted(KNOWN_KEYS))}")
    learners = _as_list(record.get("learners"), "learners")
    for name in learners:
        learner(name)  # an unknown learner is named with the choices
    settings = [Setting(kind, _setting_value(kind, value, folder))
                for kind in SETTING_KINDS for value in _as_list(record.get(kind, []), kind, allow_empty=True)]
    if not settings:
        raise ConfigError(f"the sweep spec names no setting: give one of {', '.join(SETTING_KINDS)}")
    seeds = record.get("seeds", 1)
    seeds = list(range(seeds)) if isinstance(seeds, int) and not isinstance(seeds, bool) else _as_list(seeds, "seeds")
    if not seeds or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds):
        raise ConfigError(f"seeds: a count >= 1 or a list of integers >= 0, got {record.get('seeds')!r}")
    budget_record = record.get("budget", {})
    if not isinstance(budget_record, dict):
        raise ConfigError(f"budget: a mapping (max_episodes, max_wall_s, check_every), got {budget_record!r}")
    try:
        budget = Budget(**budget_record)
    except TypeError as error:
        raise ConfigError(f"budget: {error}") from None
    randomize = record.get("randomize", "") or ""
    if randomize:
        from pendkit.sim.randomize import parse_randomize

        randomize = ",".join(parse_randomize(randomize))
    agent = record.get("agent", {}) or {}
    if not isinstance(agent, dict):
        raise ConfigError(f"agent: a mapping of agent settings, got {agent!r}")
    trials = tuple(Trial(name, setting, seed, budget, randomize, dict(agent))
                   for setting, name, seed in itertools.product(settings, learners, seeds))
    ids = [t.trial_id for t in trials]
    if len(set(ids)) != len(ids):
        raise ConfigError("the sweep spec names the same trial twice (a repeated learner, setting or seed)")
    return SweepSpec(str(record.get("name", "sweep")), trials, record)


def _as_list(value, key: str, allow_empty: bool = False) -> list:
    if value is None or (isinstance(value, list) and not value and not allow_empty):
        raise ConfigError(f"the sweep spec needs {key}: a list")
    return value if isinstance(value, list) else [value]


def _setting_value(kind: str, value, folder: Path):
    if kind == "fidelities":
        from pendkit.sim.fidelity import FIDELITY_PRESETS

        if value not in FIDELITY_PRESETS:
            raise ConfigError(f"fidelities: unknown {value!r}; choose from {', '.join(FIDELITY_PRESETS)}")
        return value
    if kind == "delay_steps":
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            raise ConfigError(f"delay_steps: whole steps >= 0, got {value!r}")
        return value
    if kind == "delay_ms":
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < 10_000:
            raise ConfigError(f"delay_ms: milliseconds in [0, 10000), got {value!r}")
        return float(value)
    path = Path(str(value))
    path = path if path.is_absolute() else folder / path
    if not path.is_file():
        raise ConfigError(f"rigs: no parameter file at {path}")
    return str(path.resolve())
