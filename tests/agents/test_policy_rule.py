"""The kit's one rule for a policy: many starts, never one episode."""

import pytest
from click.testing import CliRunner

from pendkit.agents.policy_rule import (
    JUDGE_SEED,
    REPORT_SEED,
    RULE_MIN_HELD,
    RULE_STARTS,
    judge_policy,
    train_until_solved,
)
from pendkit.agents.pretrained import policy_weights
from pendkit.agents.runs import build_run
from pendkit.cli import main


class LuckyOnlyFromRest:
    """The shipped ideal policy, except that on every second greedy episode it keeps the arm still: it holds
    from hanging (the old one-episode check) and fails the random starts, while `flaky` is set."""

    def __init__(self, agent) -> None:
        self.agent, self.flaky, self.greedy_episodes, self._fresh = agent, True, 0, False

    def __getattr__(self, name):
        return getattr(self.agent, name)

    def reset(self) -> None:
        self._fresh = True
        self.agent.reset()

    def act(self, x, explore: bool = True):
        if not explore and self._fresh:
            self.greedy_episodes += 1
        self._fresh = False
        action = self.agent.act(x, explore=explore)
        return 0 if not explore and self.flaky and self.greedy_episodes % 2 == 0 else action


def shipped_ideal(**agent_overrides):
    spec, state = policy_weights("dqn-ideal")
    spec = spec.__class__(**{**spec.to_dict(), "agent": {**spec.agent, **agent_overrides}})
    env, agent, inputs = build_run(spec)
    agent.load_state_dict(state)
    return env, agent, inputs


def test_the_rule_is_ten_starts_half_random_half_hanging_nine_must_hold():
    assert len(RULE_STARTS) == 10 and RULE_STARTS.count("rest") == 5 and RULE_MIN_HELD == 9
    assert JUDGE_SEED + len(RULE_STARTS) <= REPORT_SEED  # reported starts are never the training checks' starts


def test_a_policy_that_holds_from_every_start_is_solved():
    env, agent, inputs = shipped_ideal()
    verdict = judge_policy(env, agent, inputs)
    assert verdict.complete and verdict.solved and verdict.held >= RULE_MIN_HELD
    assert verdict.held_by_start() == {"rest": "5/5", "random": "5/5"}


def test_one_lucky_episode_is_not_a_policy():
    env, agent, inputs = shipped_ideal()
    lucky = LuckyOnlyFromRest(agent)
    full = judge_policy(env, lucky, inputs)
    assert full.evaluation.solved[0] and not full.solved and full.held_by_start() == {"rest": "5/5", "random": "0/5"}
    early = judge_policy(env, lucky, inputs, stop_when_decided=True)
    assert len(early.starts) == 4 and not early.solved  # two misses decide it
    cannot_tie = judge_policy(env, lucky, inputs, need=8)  # another candidate held 8: stop when 8 is out of reach
    assert len(cannot_tie.starts) == 6 and cannot_tie.held == 3  # rest, random, ..., the third random miss


def test_training_counts_episodes_when_the_whole_rule_first_passes_not_the_screen():
    env, agent, inputs = shipped_ideal(learning_starts=10**9, epsilon_start=0.0, epsilon_end=0.0)  # never learns
    lucky, verdicts = LuckyOnlyFromRest(agent), []

    def on_check(episodes, wall_s, verdict):
        verdicts.append((episodes, verdict))
        lucky.flaky = False  # from the second check on, it holds from every start

    returns, solved_at = train_until_solved(env, lucky, inputs, max_episodes=6, check_every=2, on_check=on_check,
                                            progress=False)
    (first_at, first), (second_at, second) = verdicts[:2]
    assert first.evaluation.solved[0] and not first.solved  # the screen held, the rule did not: training went on
    assert second.solved and second.complete and solved_at == second_at == 4 and len(returns) == 4


def test_eval_prints_the_rule_and_the_verdict():
    result = CliRunner().invoke(main, ["eval", "--policy", "dqn-ideal"])
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[1].startswith("rule: a policy is solved when >= 9 of 10 greedy episodes")
    assert lines[2] == "policy: policy_solved=10/10 (yes) rest=5/5 random=5/5"
    short = CliRunner().invoke(main, ["eval", "--policy", "dqn-ideal", "--episodes", "2"])
    assert "policy: not judged" in short.output


def test_held_fraction_counts_falls_after_a_catch_not_a_pass_over_the_top():
    from pendkit.agents.runs import CAUGHT_STEPS, held_fraction

    down, up = [3.0] * 40, [0.1] * 200
    passing_over = [0.2] * (CAUGHT_STEPS - 5)
    assert held_fraction(down + passing_over + down + up) == 1.0
    fall = [1.5] * 20
    held = held_fraction(down + up + fall + up)
    assert held == pytest.approx(400 / 420)
    assert held_fraction(down + passing_over + down) is None
