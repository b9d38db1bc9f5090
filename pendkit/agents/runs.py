"""A learning run: what it is made of (`RunSpec`), the one place its env and learner are built (`build_run`),
the one weights format a trained agent is saved in, and the kit's "solved" test of a greedy episode.

The CLI (`pendkit train/eval`), the shipped policies (`pendkit.agents.pretrained`) and the benchmarks all go
through here, so a run trained by one is loaded by the others.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

from pendkit.agents.base import Agent
from pendkit.agents.inputs import StepInputs
from pendkit.agents.learners import build_learner, check_agent_settings, learner
from pendkit.agents.spec_checks import check_run_spec
from pendkit.env import OBSERVED_SOURCES
from pendkit.episode import run_episode
from pendkit.errors import ConfigError
from pendkit.features import SOLVED_TAIL_STEPS, UPRIGHT_RAD, holds_upright, time_to_upright_s
from pendkit.rig import RigParams
from pendkit.sim.observation_delay import ObservationDelay
from pendkit.sim.randomize import DomainRandomization, observer_bank

# pendkit modules that load torch are imported inside the functions that use them: importing this module does not need
# them (start-up; torch is an optional extra).

WEIGHTS_FORMAT = "pendkit-weights/1"
OBSERVERS = ("base", "rig", "bank")  # RunSpec.observer: what a learner's observer is designed for
SOLVED_SEED = 123  # one greedy episode's default start seed (the rule's training starts begin here too)


@dataclass(frozen=True)
class RunSpec:
    """Everything a run is built from. `preset`: a servo preset of RigParams (None: the default rig);
    `randomize`: domain randomisation per episode (`pendkit.sim.randomize`); `delay_steps`: whole 60 ms
    steps of pure observation delay on top (`ObservationDelay`); `agent`: overrides of the agent's config;
    `observer` (a learner reading the observer's estimate, over randomised rigs): "base", the observer keeps
    the base rig's design, as on a rig the laptop knows nothing of; "rig", it is designed for each drawn rig,
    for a policy whose observer will be given its rig (`pendkit adapt` gives it the identified one); "bank",
    the fixed bank of observers (`pendkit.sim.randomize.observer_bank`) a rig nobody identified is met with."""

    learner: str = "dqn"
    fidelity: str = "ideal"  # a preset's name (a Fidelity object also serves, in runs that are not saved)
    seed: int = 0
    max_steps: int = 500
    preset: str | None = None
    randomize: str = ""
    delay_steps: int = 0
    agent: dict = field(default_factory=dict)
    observer: str = "base"

    def __post_init__(self) -> None:
        check_run_spec(self)  # every field's type and range (a run folder is input like any other)
        learner(self.learner)  # an unknown name, with the known ones
        if not isinstance(self.observer, str) or self.observer not in OBSERVERS:
            raise ConfigError(f"observer must be one of {', '.join(OBSERVERS)}, got {self.observer!r}")

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, record: dict) -> RunSpec:
        """From `to_dict`'s output (or a run's config.json, whose older form said "algo"), every field and agent
        setting checked (`pendkit.agents.spec_checks`)."""
        if not isinstance(record, dict):
            raise ConfigError(f"a run spec is an object of named fields, got {type(record).__name__}")
        known = {f.name for f in fields(cls)}
        values = {key: value for key, value in record.items() if key in known}
        if "learner" not in values and "algo" in record:
            values["learner"] = record["algo"]
        spec = cls(**values)
        if spec.agent:
            check_agent_settings(spec.learner, spec.agent)  # the agent's own names and types (imports torch)
        return spec


def make_env(spec: RunSpec, **env_options):
    """The env `spec` learns on; `env_options` go to `pendkit.make` (a rig backend, a start, ...)."""
    import pendkit

    params = RigParams.preset(spec.preset) if spec.preset else env_options.pop("params", None)
    chosen = learner(spec.learner)
    if spec.observer == "bank" and chosen.features in OBSERVED_SOURCES:
        env_options.setdefault("observer_params", observer_bank())
    env = chosen.wrap(pendkit.make(fidelity=spec.fidelity, max_episode_steps=spec.max_steps, params=params,
                                   **chosen.env_kwargs(), **env_options))
    if spec.delay_steps:
        env = ObservationDelay(env, spec.delay_steps)
    if spec.randomize:
        env = DomainRandomization(env, spec.randomize, spec.seed, observer_follows_rig=spec.observer == "rig")
    return env


def build_run(spec: RunSpec, env=None) -> tuple[object, Agent, StepInputs]:
    """(env, agent, inputs) for `spec`; on `env` if one is given (the same learner on another rig)."""
    env = env if env is not None else make_env(spec)
    agent, inputs = build_learner(spec.learner, env, spec.seed, **spec.agent)
    return env, agent, inputs


def save_weights(path: str | Path, agent: Agent, spec: RunSpec, notes: dict | None = None) -> Path:
    """The agent's state with the spec that rebuilds it: what `load_weights` and `pendkit eval` read (as data
    only: `pendkit.agents.data_files`)."""
    from pendkit.agents.data_files import save_data

    return save_data(path, {"format": WEIGHTS_FORMAT, "spec": spec.to_dict(), "agent": agent.state_dict(),
                            "notes": notes or {}})


def load_weights(path: str | Path) -> tuple[RunSpec, dict]:
    """(spec, agent state) from a weights file, or from a training checkpoint (its agent state; the spec
    from the run's config.json beside it)."""
    import json

    from pendkit.agents.data_files import load_data

    path = Path(path)
    if not path.exists():
        raise ConfigError(f"no weights at {path}")
    record = load_data(path)
    try:
        if isinstance(record, dict) and record.get("format") == WEIGHTS_FORMAT:
            return RunSpec.from_dict(record["spec"]), record["agent"]
        config = path.parent / "config.json"
        if isinstance(record, dict) and "agent" in record and config.exists():
            return RunSpec.from_dict(json.loads(config.read_text())), record["agent"]
    except (TypeError, ValueError, KeyError) as error:
        raise ConfigError(f"{path}: its run spec is not one the kit can build: {error}") from None
    raise ConfigError(f"{path} is neither a weights file ({WEIGHTS_FORMAT}) nor a checkpoint beside its config.json")


def greedy_episode(env, agent: Agent, inputs: StepInputs, seed: int = SOLVED_SEED, start: str | None = "rest",
                   options: dict | None = None) -> tuple[float, list[dict]]:
    """One episode without exploration (from `start`); (return, infos)."""
    from pendkit.agents.train import agent_episode

    options = {**({"start": start} if start else {}), **(options or {})}
    return agent_episode(env, agent, inputs, seed=seed, explore=False, options=options)


def solved(infos: list[dict], tail_steps: int = SOLVED_TAIL_STEPS) -> bool:
    """One episode holds: within 0.3 rad of upright for its last `tail_steps` steps (a *policy* is solved
    only by the rule over many starts: `pendkit.agents.policy_rule`)."""

    return holds_upright([info["angle_from_upright_rad"] for info in infos], tail_steps)


CAUGHT_STEPS = 15  # 0.9 s at the rig's 60 ms: longer than a swing takes to pass over the top


def held_fraction(angles_from_upright_rad) -> float | None:
    """Of the steps after the pendulum first comes up and is caught (the first CAUGHT_STEPS steps in a row
    within 0.3 rad of upright), the fraction that stay within it: 1.0 when nothing knocks it out once up, less
    for every step of a fall and a swing back. A pass over the top that is not caught is part of the swing-up,
    not a fall. None if it is never caught."""
    import numpy as np

    inside = np.abs(np.asarray(angles_from_upright_rad)) < UPRIGHT_RAD
    if len(inside) < CAUGHT_STEPS:
        return None
    runs = np.convolve(inside, np.ones(CAUGHT_STEPS, dtype=int), mode="valid")
    caught = np.nonzero(runs == CAUGHT_STEPS)[0]
    return float(np.mean(inside[caught[0]:])) if len(caught) else None


@dataclass(frozen=True)
class Evaluation:
    """Greedy episodes' outcomes: solved or not (the kit's rule), time to upright (s, None if it never
    stayed up to the end), return and held fraction, one entry per episode."""

    solved: list[bool]
    upright_s: list[float | None]
    returns: list[float]
    held_fractions: list[float | None] = field(default_factory=list)

    def __add__(self, other: Evaluation) -> Evaluation:
        return Evaluation(self.solved + other.solved, self.upright_s + other.upright_s,
                          self.returns + other.returns, self.held_fractions + other.held_fractions)

    @property
    def min_held_fraction(self) -> float | None:
        """The worst held fraction among the solved episodes."""
        return min((f for f, ok in zip(self.held_fractions, self.solved) if ok and f is not None), default=None)

    @property
    def mean_return(self) -> float:
        return sum(self.returns) / len(self.returns)

    @property
    def median_upright_s(self) -> float | None:
        import numpy as np

        times = [t for t, held in zip(self.upright_s, self.solved) if held and t is not None]
        return float(np.median(times)) if times else None

    def summary(self) -> str:
        """`solved=K/N median_upright_s=X` (X over the solved episodes; `-` when none)."""
        median = self.median_upright_s
        shown = "-" if median is None else f"{median:.2f}"
        return f"solved={sum(self.solved)}/{len(self.solved)} median_upright_s={shown}"


def judged_episode(angles_from_upright_rad, step_s: float, episode_return: float = 0.0) -> Evaluation:
    """One episode (its angles from upright, a step apart) judged as every episode in the kit is: held by the
    solved rule's tail, its time to upright, its return and its held fraction."""

    angles = list(angles_from_upright_rad)
    return Evaluation([holds_upright(angles, SOLVED_TAIL_STEPS)], [time_to_upright_s(angles, step_s)],
                      [float(episode_return)], [held_fraction(angles)])


def judged_episodes(runs, step_s: float, returns=None) -> Evaluation:
    """Several episodes' angles judged by `judged_episode` (returns 0 unless given)."""
    returns = [0.0] * len(runs) if returns is None else returns
    return sum((judged_episode(angles, step_s, r) for angles, r in zip(runs, returns)), Evaluation([], [], [], []))


def judge_runs(env, policy, starts, seed: int, said=None) -> Evaluation:
    """`policy` (any `run_episode` policy, e.g. a classical controller) for one episode per entry of `starts`
    (None: as the env starts, e.g. a rig hanging still), episode k from seed `seed + k`, each judged by
    `judged_episode`; `said(k, start, one_episode)` after each, for a progress line."""

    outcome = Evaluation([], [], [], [])
    for k, start in enumerate(starts):
        trace = run_episode(env, policy, seed=seed + k, options={"start": start} if start else None)
        one = judged_episode(trace.pendulum_from_upright_rad, env.unwrapped.dt, trace.episode_return)
        outcome += one
        if said is not None:
            said(k, start, one)
    return outcome


def evaluate_agent(env, agent: Agent, inputs: StepInputs, episodes: int, seed: int = 10_000,
                   start: str | None | list[str] = "random") -> Evaluation:
    """`episodes` greedy episodes from seeds `seed`, `seed + 1`, ...; `start` for all of them or one per
    episode (None leaves the env's own)."""
    starts = start if isinstance(start, list) else [start] * episodes
    outcome = Evaluation([], [], [], [])
    for k, first in enumerate(starts[:episodes]):
        total, infos = greedy_episode(env, agent, inputs, seed=seed + k, start=first)
        outcome += judged_episode([info["angle_from_upright_rad"] for info in infos], env.unwrapped.dt, total)
    return outcome
