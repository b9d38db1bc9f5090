"""The kit's one rule for a learned policy that holds, used by training checks, sweeps, `pendkit eval`, the
benchmarks and the labs.

A policy is *solved* when at least 9 of 10 greedy episodes hold: 5 from the authors' random starts and 5
hanging still, each holding within 0.3 rad of upright for its last 200 steps. One lucky episode is not a
policy: returns vary by two orders of magnitude with the start state.

Training is judged on the starts drawn from `JUDGE_SEED`; every number the kit reports comes from
`REPORT_SEED`'s starts, which training never saw. A training check screens first with the rule's own first
episode (hanging still) and runs the rest only when it holds; "episodes to solve" counts when the whole
rule first passes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from pendkit.agents.base import Agent
from pendkit.agents.inputs import StepInputs
from pendkit.agents.runs import SOLVED_TAIL_STEPS, Evaluation, greedy_episode, judged_episode
from pendkit.agents.train import train_sync
from pendkit.features import UPRIGHT_RAD

RULE_STARTS = ("rest", "random") * 5  # interleaved: a check stopped early has seen both kinds
RULE_MIN_HELD = 9
JUDGE_SEED = 123  # the starts training is judged on
REPORT_SEED = 10_000  # the starts reported numbers come from (never seen by a training check)
RULE_TEXT = (f"a policy is solved when >= {RULE_MIN_HELD} of {len(RULE_STARTS)} greedy episodes "
             f"({RULE_STARTS.count('random')} random starts, {RULE_STARTS.count('rest')} hanging still) hold "
             f"|theta| < {UPRIGHT_RAD:g} rad for their last {SOLVED_TAIL_STEPS} steps")

# the bar a shipped policy is held to on its own twin (issue 43; benchmarks/bench_policies.py measures it)
SHIPPED_RANDOM, SHIPPED_REST, SHIPPED_HELD_MIN = (19, 20), (10, 10), 0.99
SHIPPED_TEXT = (f">= {SHIPPED_RANDOM[0]}/{SHIPPED_RANDOM[1]} random starts, {SHIPPED_REST[0]}/{SHIPPED_REST[1]} "
                f"hanging, held_min >= {SHIPPED_HELD_MIN}")


def meets_shipped_bar(figures: dict) -> bool:
    """Whether `bench_policies`' figures for a policy on its twin ({"solved": "k/n", "rest": "k/n",
    "held_min": float}) reach the shipped bar, on at least as many episodes as it names."""
    def reaches(text: str, bar: tuple[int, int]) -> bool:
        held, episodes = (int(part) for part in text.split("/"))
        return episodes >= bar[1] and held * bar[1] >= bar[0] * episodes

    held_min = figures.get("held_min")
    return (reaches(figures["solved"], SHIPPED_RANDOM) and reaches(figures["rest"], SHIPPED_REST)
            and held_min is not None and held_min >= SHIPPED_HELD_MIN)


@dataclass(frozen=True)
class PolicyVerdict:
    """The rule's episodes (fewer when a check stopped once the outcome was decided) and the verdict."""

    evaluation: Evaluation
    starts: tuple[str | None, ...]
    seed: int

    @property
    def held(self) -> int:
        return sum(self.evaluation.solved)

    @property
    def solved(self) -> bool:
        return self.held >= RULE_MIN_HELD

    @property
    def complete(self) -> bool:
        return len(self.starts) == len(RULE_STARTS)

    def held_by_start(self) -> dict[str, str]:
        """`{"random": "k/n", "rest": "k/n"}` over the episodes run."""
        shown = {}
        for kind in dict.fromkeys(s for s in self.starts if s is not None):
            outcomes = [ok for ok, start in zip(self.evaluation.solved, self.starts) if start == kind]
            shown[kind] = f"{sum(outcomes)}/{len(outcomes)}"
        return shown

    def summary(self, label: str = "policy") -> str:
        """`policy_solved=K/N (yes|no)`, N = the episodes run (10 unless a check stopped early)."""
        return f"{label}_solved={self.held}/{len(self.starts)} ({'yes' if self.solved else 'no'})"


def rule_starts(on_twin: bool = True) -> tuple[str | None, ...]:
    """The rule's starts; on a rig (which starts as it is) None for each."""
    return RULE_STARTS if on_twin else (None,) * len(RULE_STARTS)


def judge_policy(env, agent: Agent, inputs: StepInputs, seed: int = REPORT_SEED, stop_when_decided: bool = False,
                 screen: bool = False, on_twin: bool = True, need: int | None = None) -> PolicyVerdict:
    """Run the rule's greedy episodes (episode k from seed `seed + k`). `stop_when_decided`: stop as soon as
    the verdict cannot change (two misses). `screen`: stop after the first episode if it does not hold (a
    training check's cheap probe). `need`: stop as soon as fewer than `need` episodes can still hold (a
    candidate that can no longer beat another)."""
    starts = rule_starts(on_twin)
    outcome, run = Evaluation([], [], [], []), []
    for k, start in enumerate(starts):
        total, infos = greedy_episode(env, agent, inputs, seed=seed + k, start=start)
        outcome += judged_episode([info["angle_from_upright_rad"] for info in infos], env.unwrapped.dt, total)
        held = outcome.solved[-1]
        run.append(start)
        misses = len(run) - sum(outcome.solved)
        if (screen and k == 0 and not held) or (stop_when_decided and misses > len(starts) - RULE_MIN_HELD):
            break
        if need is not None and len(starts) - misses < need:
            break
    return PolicyVerdict(outcome, tuple(run), seed)


def train_until_solved(env, agent: Agent, inputs: StepInputs, max_episodes: int, check_every: int = 10,
                       probe=None, probe_inputs: StepInputs | None = None, max_wall_s: float = float("inf"),
                       on_check=None, spent_s: float = 0.0, **train_options) -> tuple[list[float], int | None]:
    """Train, and every `check_every` episodes judge the greedy policy on `probe` (default: `env`) by the
    kit's rule (`pendkit.agents.policy_rule`, on the training starts: screened by its first episode, the
    rest only when that holds); stop once the rule passes or after `max_episodes` (or `max_wall_s` seconds,
    counted from `spent_s` before a resume). Returns (every episode's return, the episodes it took, or None).
    `on_check(episodes, wall_s, verdict)` sees each check (a `PolicyVerdict`); `train_options` go to
    train_sync."""
    probe = env if probe is None else probe
    probe_inputs = inputs if probe_inputs is None else probe_inputs  # each episode resets them: sharing is safe
    started = time.perf_counter() - spent_s
    outcome = {"solved_at": None}

    def check(episodes_done: int, returns: list[float]):
        if episodes_done % check_every and episodes_done < max_episodes:
            return True
        verdict = judge_policy(probe, agent, probe_inputs, JUDGE_SEED, stop_when_decided=True, screen=True)
        wall_s = time.perf_counter() - started
        if on_check is not None:
            on_check(episodes_done, wall_s, verdict)
        if verdict.solved:
            outcome["solved_at"] = episodes_done
            return False
        return wall_s <= max_wall_s

    returns = train_sync(env, agent, max_episodes, inputs, on_episode=check, **train_options)
    return returns, outcome["solved_at"]
