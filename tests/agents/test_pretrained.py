"""Shipped policies: choosing a checkpoint by validation, and what `pendkit policies` says about them."""

import copy

import pytest
import torch
from click.testing import CliRunner

from pendkit.agents.policy_rule import SHIPPED_TEXT, meets_shipped_bar
from pendkit.agents.pretrained import POLICIES, PretrainedSpec, train_keeping_best
from pendkit.agents.rig_suite import random_rigs, validation_rigs
from pendkit.agents.runs import RunSpec, build_run
from pendkit.cli import main


def _same(a: dict, b: dict) -> bool:
    return all(torch.equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize("best_check", [0, 1, 2])
def test_training_keeps_the_best_scored_checkpoint_not_the_last(best_check):
    spec = PretrainedSpec(RunSpec("dqn", "ideal", seed=3), episodes=6, check_every=2)
    env, agent, inputs = build_run(spec.run)
    seen = []

    def score(_spec, state):  # a scripted preference: which check wins is the test's parameter
        seen.append(copy.deepcopy(state))
        return (1 if len(seen) - 1 == best_check else 0, -float(len(seen)))

    returns, chosen = train_keeping_best(env, agent, inputs, spec, score)
    assert len(returns) == 6 and len(seen) == 3
    assert chosen["chosen_at_episode"] == 2 * (best_check + 1)
    assert _same(agent.state_dict()["q"], seen[best_check]["q"])
    if best_check < 2:  # the agent went back: it is no longer what it was at the end
        assert not _same(agent.state_dict()["q"], seen[2]["q"])


def test_validation_rigs_come_from_the_training_ranges_and_are_not_the_held_out_ones():
    from pendkit.sim.randomize import TRAINING_RANGES

    validation, held_out = validation_rigs(), random_rigs()
    assert validation == validation_rigs()  # one documented draw
    fresh = validation_rigs(3, after=5)  # a later choice's rigs: the same draw, past the first five
    assert list(fresh) == ["validation-05", "validation-06", "validation-07"]
    assert [r.params for r in fresh.values()] == [r.params for r in list(validation_rigs(8).values())[5:]]
    speeds = [rig.params.servo_speed_s_per_60deg for rig in validation.values()]
    low, high = TRAINING_RANGES.servo_speed_s_per_60deg
    assert all(low <= s <= high for s in speeds)
    assert not {r.params for r in validation.values()} & {r.params for r in held_out.values()}


def test_policies_list_names_the_robust_policy_and_that_it_is_built_only_when_named():
    out = CliRunner().invoke(main, ["policies", "list", "--all"]).output
    assert "r-dqn-robust" in out and "over rigs (robust)" in out and "built only when named" in out
    assert not POLICIES["r-dqn-robust"].built_by_default and POLICIES["r-dqn-realistic"].built_by_default


def test_the_robust_policy_swings_up_and_holds_the_default_rig_from_rest():
    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.rig_suite import policy_on_rigs
    from pendkit.rig import RigParams
    from pendkit.sim.randomize import RandomRig

    spec, state = policy_weights("r-dqn-robust")
    outcome = policy_on_rigs(spec, state, {"default": RandomRig(RigParams(), None, 0)}, starts=0)["default"]
    assert outcome.solved == [True]  # the kit's rule: within 0.3 rad for the last 200 steps
    # simulated seconds on a seeded twin, not wall-clock time: the same on any machine
    assert outcome.upright_s[0] < 8.0 and outcome.held_fractions[0] > 0.9


def test_policies_list_prints_each_policys_measured_figures_and_how_they_were_measured():
    from pendkit.agents.pretrained import measured_figures

    measured, command = measured_figures()
    assert set(measured) == set(POLICIES) and command.startswith("python benchmarks/bench_policies.py")
    out = CliRunner().invoke(main, ["policies", "list", "--all"]).output
    for name, conditions in measured.items():
        figures = conditions["twin"]
        block = out.split(name, 1)[1]
        assert f"measured on its twin: random starts {figures['solved']}, hanging {figures['rest']}" in block
        verdict = block.split("the shipped bar on its twin", 1)[0].rsplit("\n", 1)[1].strip()
        assert verdict == ("meets" if meets_shipped_bar(figures) else "below"), name
        if verdict == "below":  # a policy under the bar says what it is kept for
            assert POLICIES[name].role and POLICIES[name].role in block.replace("\n", " ")
    assert f"measured by: {command}" in out and f"the shipped bar: {SHIPPED_TEXT}" in out
    # what lab 09 deploys: exactly the policies the list says meet the bar, in the list's order
    from pendkit.agents.pretrained import policies_that_hold

    assert policies_that_hold() == [name for name in POLICIES if meets_shipped_bar(measured[name]["twin"])]
    # without --all: only the policies that hold, each meeting the bar; the rest named once as kept below it
    shown = CliRunner().invoke(main, ["policies", "list"]).output
    listed = [line.split()[0] for line in shown.splitlines() if line[:1].strip() and line.split()[0] in POLICIES]
    assert listed == policies_that_hold() and "below the shipped bar" not in shown
    below = [name for name in POLICIES if name not in listed]
    assert f"also kept, below the bar (for studies and the device's blobs): {', '.join(below)}" in shown


def test_the_shipped_bar_needs_every_part_on_enough_episodes():
    good = {"solved": "19/20", "rest": "10/10", "held_min": 0.99}
    assert meets_shipped_bar(good)
    assert not meets_shipped_bar({**good, "solved": "18/20"})
    assert not meets_shipped_bar({**good, "solved": "2/2"})  # too few episodes to say
    assert not meets_shipped_bar({**good, "rest": "9/10"})
    assert not meets_shipped_bar({**good, "held_min": 0.98})
    assert not meets_shipped_bar({**good, "held_min": None})


@pytest.mark.parametrize("name, start, seed", [("td3-realistic", "random", 10_000), ("td3-realistic", "rest", 10_500),
                                               ("td3-realistic", "random", 10_007), ("dqn-ideal", "random", 10_003),
                                               ("r-td3-robust", "rest", 10_501),
                                               ("r-dqn-levels-realistic", "random", 10_004),
                                               ("r-td3-bank-robust", "random", 10_005)])
def test_a_shipped_policy_holds_starts_it_was_never_judged_on(name, start, seed):
    import pendkit
    from pendkit.agents.pretrained import policy_env_options, policy_weights
    from pendkit.agents.runs import evaluate_agent, make_env

    spec, state = policy_weights(name)
    env = make_env(spec)
    _, agent, inputs = build_run(spec, env)
    agent.load_state_dict(state)
    outcome = evaluate_agent(env, agent, inputs, 1, seed, start)
    assert outcome.solved == [True], outcome
    on_a_rig = pendkit.make(**policy_env_options(name)).unwrapped
    assert on_a_rig.feature_source == env.unwrapped.feature_source
    # what it meets on a rig nobody identified is what it was trained with (a bank-trained one: the bank)
    assert type(on_a_rig._estimator) is type(env.unwrapped._estimator)


def test_a_policy_of_target_levels_drives_a_plain_continuous_env_and_holds():
    import numpy as np

    import pendkit
    from pendkit.agents.pretrained import load_policy, policy_env_options
    from pendkit.episode import run_episode
    from pendkit.features import holds_upright

    env = pendkit.make(**policy_env_options("r-dqn-levels-realistic"), start="rest")
    assert env.action_space.shape == (1,)  # what a rig or lab 09's guarded run gives it
    policy = load_policy("r-dqn-levels-realistic", env)
    policy.reset()
    targets = []
    trace = run_episode(env, policy, seed=10_503, on_step=lambda action, *rest: targets.append(action))
    assert set(np.round(np.concatenate(targets), 3)) <= set(np.round(np.linspace(-1, 1, 9), 3))
    assert holds_upright(trace.pendulum_from_upright_rad, 200)


def test_keeping_a_checkpoint_by_rigs_and_the_default_rig_adds_the_default_rigs_held_episodes():
    from pendkit.agents.pretrained import policy_weights, validation_and_default_score, validation_score
    from pendkit.errors import ConfigError

    run, state = policy_weights("td3-realistic")
    spec = PretrainedSpec(run, 10, check_every=5, validation_rigs=2, kept_by="rigs+default")
    said = []
    total, mean_return = validation_and_default_score(spec, state, starts=1, say=said.append)
    rigs, _ = validation_score(spec, state)
    held, episodes = (int(n) for n in said[0].rsplit("default rig ", 1)[1].split("/"))
    assert episodes == 2 and total == rigs + held and f"validation rigs {rigs}" in said[0]
    with pytest.raises(ConfigError, match="kept_by must be one of"):
        PretrainedSpec(run, 10, kept_by="luck")
