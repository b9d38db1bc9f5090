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
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from pendkit.agents.learners import check_agent_settings, learner
from pendkit.agents.spec_checks import SPEC_BOUNDS, is_whole
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS
from pendkit.sim.randomize import parse_randomize

SETTING_KINDS = ("fidelities", "delay_steps", "delay_ms", "rigs")
KNOWN_KEYS = {"name", "learners", "seeds", "budget", "randomize", "agent", *SETTING_KINDS}
MAX_TRIALS = 10_000  # a spec that expands to more is a typo (seeds: 1000000), refused before it is built
MAX_SEED = 2**32 - 1  # numpy's and torch's seeds
NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")  # a folder name inside --out, never a path


@dataclass(frozen=True)
class Budget:
    """How long a trial may learn, and how often its greedy policy is checked (episodes)."""

    max_episodes: int = 200
    max_wall_s: float = 600.0
    check_every: int = 10

    def __post_init__(self) -> None:
        whole = all(isinstance(v, int) and not isinstance(v, bool) for v in (self.max_episodes, self.check_every))
        number = isinstance(self.max_wall_s, (int, float)) and not isinstance(self.max_wall_s, bool)
        if not (whole and number) or self.max_episodes < 1 or self.check_every < 1 or not (
                math.isfinite(self.max_wall_s) and self.max_wall_s > 0):
            raise ConfigError("budget: max_episodes and check_every whole numbers >= 1, max_wall_s seconds > 0, "
                              f"got {self.max_episodes!r}, {self.check_every!r}, {self.max_wall_s!r}")


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
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise ConfigError(f"{path}: cannot read it as text ({error})") from None
    if path.suffix in (".yaml", ".yml"):
        try:
            import yaml
        except ImportError:
            raise ConfigError('a YAML spec needs PyYAML: pip install -e ".[cluster]" (or write the spec as '
                              "TOML)") from None
        try:
            record = yaml.safe_load(text)  # safe: a !!python tag is refused, never run
        except yaml.YAMLError as error:
            mark = getattr(error, "problem_mark", None)
            where = f":{mark.line + 1}:{mark.column + 1}" if mark is not None else ""
            problem = getattr(error, "problem", None) or str(error).splitlines()[0]
            raise ConfigError(f"{path}{where}: not valid YAML ({problem})") from None
    elif path.suffix == ".toml":
        import tomllib

        try:
            record = tomllib.loads(text)
        except tomllib.TOMLDecodeError as error:
            raise ConfigError(f"{path}: not valid TOML ({error})") from None
    elif path.suffix == ".json":
        try:
            record = json.loads(text)
        except json.JSONDecodeError as error:
            raise ConfigError(f"{path}:{error.lineno}:{error.colno}: not valid JSON ({error.msg})") from None
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

    unknown = sorted(set(record) - KNOWN_KEYS)
    if unknown:
        raise ConfigError(f"unknown keys in the sweep spec: {', '.join(unknown)}; "
                          f"known: {', '.join(sorted(KNOWN_KEYS))}")
    name = record.get("name", "sweep")
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ConfigError(f"name: letters, digits, '.', '-' and '_' (at most 64, no path), got {name!r}")
    learners = _as_list(record.get("learners"), "learners")
    for learner_name in learners:
        if not isinstance(learner_name, str):
            raise ConfigError(f"learners: names, got {learner_name!r}")
        learner(learner_name)  # an unknown learner is named with the choices
    settings = [Setting(kind, _setting_value(kind, value, folder))
                for kind in SETTING_KINDS for value in _as_list(record.get(kind, []), kind, allow_empty=True)]
    if not settings:
        raise ConfigError(f"the sweep spec names no setting: give one of {', '.join(SETTING_KINDS)}")
    seeds = record.get("seeds", 1)
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        if not 1 <= seeds <= MAX_TRIALS:
            raise ConfigError(f"seeds: a count in [1, {MAX_TRIALS}] or a list of seeds, got {seeds}")
        seeds = list(range(seeds))
    seeds = _as_list(seeds, "seeds")
    if not seeds or not all(isinstance(s, int) and not isinstance(s, bool) and 0 <= s <= MAX_SEED for s in seeds):
        raise ConfigError(f"seeds: a count >= 1 or a list of integers in [0, {MAX_SEED}], got {record.get('seeds')!r}")
    count = len(learners) * len(settings) * len(seeds)
    if count > MAX_TRIALS:
        raise ConfigError(f"the spec expands to {count} trials, more than the {MAX_TRIALS} a sweep takes: fewer "
                          "seeds, settings or learners (or several sweeps)")
    budget_record = record.get("budget", {})
    if not isinstance(budget_record, dict):
        raise ConfigError(f"budget: a mapping (max_episodes, max_wall_s, check_every), got {budget_record!r}")
    try:
        budget = Budget(**budget_record)
    except TypeError as error:
        raise ConfigError(f"budget: {error}") from None
    randomize = record.get("randomize", "") or ""
    if not isinstance(randomize, str):
        raise ConfigError(f"randomize: factors as text (e.g. servo,latency or robust), got {randomize!r}")
    if randomize:
        randomize = ",".join(parse_randomize(randomize))
    agent = record.get("agent", {}) or {}
    if not isinstance(agent, dict):
        raise ConfigError(f"agent: a mapping of agent settings, got {agent!r}")

    for learner_name in learners:
        check_agent_settings(learner_name, agent)
    trials = tuple(Trial(learner_name, setting, seed, budget, randomize, dict(agent))
                   for setting, learner_name, seed in itertools.product(settings, learners, seeds))
    ids = [t.trial_id for t in trials]
    if len(set(ids)) != len(ids):
        raise ConfigError("the sweep spec names the same trial twice (a repeated learner, setting or seed)")
    return SweepSpec(name, trials, record)


def _as_list(value, key: str, allow_empty: bool = False) -> list:
    if value is None or (isinstance(value, list) and not value and not allow_empty):
        raise ConfigError(f"the sweep spec needs {key}: a list")
    return value if isinstance(value, list) else [value]


def _setting_value(kind: str, value, folder: Path):
    if kind == "fidelities":
        if not isinstance(value, str) or value not in FIDELITY_PRESETS:
            raise ConfigError(f"fidelities: unknown {value!r}; choose from {', '.join(FIDELITY_PRESETS)}")
        return value
    if kind == "delay_steps":
        high = SPEC_BOUNDS["delay_steps"][1]  # as a run's spec takes it
        if not is_whole(value) or not 0 <= value <= high:
            raise ConfigError(f"delay_steps: whole steps >= 0 and <= {high}, got {value!r}")
        return value
    if kind == "delay_ms":
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < 10_000:
            raise ConfigError(f"delay_ms: milliseconds in [0, 10000), got {value!r}")
        return float(value)
    if not isinstance(value, str):
        raise ConfigError(f"{kind}: a parameter file's path, got {value!r}")
    path = Path(value)
    path = path if path.is_absolute() else folder / path
    if not path.is_file():
        raise ConfigError(f"rigs: no parameter file at {path}")

    try:
        RigParams.load(path)
    except (ConfigError, ValueError, TypeError, KeyError, OSError) as error:
        raise ConfigError(f"rigs: {path} is not a rig's parameter file ({error})") from None
    return str(path.resolve())
