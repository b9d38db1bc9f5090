"""What the agents see: the delay-aware input (the actions an observation has not seen), the named
learners, and the observer's estimate as features."""

import re

import gymnasium as gym
import numpy as np
import pytest

import pendkit
from pendkit.agents.inputs import StepInputs, actions_for_delay
from pendkit.errors import ConfigError
from pendkit.sim.observation_delay import ObservationDelay


def test_step_inputs_hold_the_last_d_actions_newest_first():
    inputs = StepInputs(2, gym.spaces.Discrete(3), actions_seen=3)
    x = inputs.reset([0.5, -0.5])
    assert x.shape == (2 + 3 * 3,) and inputs.dim == 11
    np.testing.assert_array_equal(x[2:], [1, 0, 0] * 3)  # before any action: "stop" (0) three times
    inputs.step([0, 0], 2)
    x = inputs.step([1, 1], 1)
    np.testing.assert_array_equal(x, [1, 1, 0, 1, 0, 0, 0, 1, 1, 0, 0])  # newest (1), then 2, then stop
    x = inputs.reset([0, 0])
    np.testing.assert_array_equal(x[2:], [1, 0, 0] * 3)  # a new episode forgets the old actions
    continuous = StepInputs(1, gym.spaces.Box(-1, 1, (1,)), actions_seen=2)
    continuous.reset([0.0])
    np.testing.assert_allclose(continuous.step([0.0], np.array([0.25])), [0.0, 0.25, 0.0])
    with pytest.raises(ConfigError, match="actions_seen"):
        StepInputs(2, gym.spaces.Discrete(3), actions_seen=0)


def test_actions_for_delay_counts_the_steps_a_reading_has_missed():
    assert actions_for_delay(0.0, 0.06) == 1
    assert actions_for_delay(0.12, 0.06) == 3  # two whole steps behind, plus the action in flight
    assert actions_for_delay(0.031, 0.06) == 2
    with pytest.raises(ConfigError):
        actions_for_delay(float("nan"), 0.06)


def test_delay_aware_learner_sees_as_many_actions_as_the_delay_hides():
    pytest.importorskip("torch")
    from pendkit.agents.base import Agent
    from pendkit.agents.learners import LEARNERS, build_learner, env_delay_s

    delayed = ObservationDelay(pendkit.make(fidelity="ideal"), 2)
    assert env_delay_s(delayed) == pytest.approx(0.12)
    _, inputs = build_learner("dqn+actions", delayed)
    assert inputs.actions_seen == 3
    _, plain = build_learner("dqn", delayed)
    assert plain.actions_seen == 1
    for name, learner in LEARNERS.items():  # every named learner builds on its env, keeps the contract and acts
        env = learner.wrap(pendkit.make(fidelity="realistic", **learner.env_kwargs()))
        agent, inputs = build_learner(name, env, seed=1)
        assert isinstance(agent, Agent) and agent.input_dim == inputs.dim, name
        x = inputs.reset(env.reset(seed=0)[0])
        agent.reset()
        assert env.action_space.contains(agent.act(x, explore=True))
        buffer = agent.new_buffer(0)
        buffer.add(x, agent.act(x), 0.0, x, False, episode=0, step=0, **agent.step_extras())
        assert len(buffer) == 1
    with pytest.raises(ConfigError, match="unknown learner"):
        build_learner("dqn+magic", delayed)
    with pytest.raises(ConfigError, match="action_mode"):
        build_learner("td3", delayed)


@pytest.mark.parametrize("action_mode", ["discrete", "continuous"])
def test_estimated_features_are_closer_to_the_truth_than_the_readings(action_mode):
    """On the realistic twin the readings lag (a mean rate over 75 ms, 0-20 ms old, the arm reported as the
    servo command); the observer's estimate of the present is much closer to the true state."""
    measured = pendkit.make(fidelity="realistic", action_mode=action_mode)
    estimated = pendkit.make(fidelity="realistic", action_mode=action_mode, features="estimated")
    rng = np.random.default_rng(0)
    errors = {"measured": [], "estimated": []}
    for name, env in (("measured", measured), ("estimated", estimated)):
        rng = np.random.default_rng(0)
        observation, info = env.reset(seed=3)
        for _ in range(200):
            action = int(rng.integers(5)) if action_mode == "discrete" else rng.uniform(-1, 1, 1).astype(np.float32)
            observation, _, _, _, info = env.step(action)
            true = info["true_state"]
            errors[name].append([observation[1] - true["arm_angle_rad"],
                                 observation[2] - true["pendulum_velocity_rad_s"]])
    rms = {name: np.sqrt(np.mean(np.square(e), axis=0)) for name, e in errors.items()}
    assert np.all(rms["estimated"] < 0.5 * rms["measured"]), rms  # arm angle and pendulum rate both
    with pytest.raises(ConfigError, match="features"):
        pendkit.make(features="guessed")


def test_both_feature_sources_show_the_estimate_then_the_readings_each_as_its_own_env_would():
    """"estimated+measured": the first half of the observation is what an estimating env shows, the second
    what a measuring env shows, step for step on the same seeded twin and actions."""
    envs = {features: pendkit.make(fidelity="realistic", action_mode="continuous", features=features)
            for features in ("estimated", "measured", "estimated+measured")}
    both = envs["estimated+measured"]
    assert both.observation_space.shape == (2 * envs["measured"].observation_space.shape[0],)
    assert both.unwrapped.observes and envs["estimated"].unwrapped.observes and not envs["measured"].unwrapped.observes
    shown = {features: [env.reset(seed=5)[0]] for features, env in envs.items()}
    for k in range(60):
        action = np.array([np.sin(k / 5)], dtype=np.float32)
        for features, env in envs.items():
            shown[features].append(env.step(action)[0])
    half = envs["measured"].observation_space.shape[0]
    together = np.array(shown["estimated+measured"])
    assert np.allclose(together[:, :half], shown["estimated"]) and np.allclose(together[:, half:], shown["measured"])
    assert not np.allclose(together[:, :half], together[:, half:])  # the two halves differ: the observer works


def test_the_shipped_delay_sweep_is_a_sweep_output_with_every_point():
    from pathlib import Path

    from pendkit.agents.policy_rule import RULE_TEXT
    from pendkit.agents.results import delay_sweep
    from pendkit.sweep.spec import load_spec

    sweep = delay_sweep()
    assert re.match(r"pendkit sweep (run )?benchmarks/sweeps/lab08-delay.yaml --out DIR", sweep.command), sweep.command
    assert sweep.solved_rule.startswith(RULE_TEXT), sweep.solved_rule  # measured under the kit's one rule
    spec = load_spec(Path(__file__).resolve().parents[2] / "benchmarks" / "sweeps" / "lab08-delay.yaml")
    assert set(sweep.success_rate) == set(spec.learners)  # the file is the spec's sweep, every learner
    assert {"dqn", "dqn+actions", "r-dqn"} <= set(sweep.success_rate)
    assert sweep.delays_ms == sorted(sweep.delays_ms) and sweep.delays_ms[0] == 0 and sweep.seeds >= 3
    for rates in sweep.success_rate.values():
        assert len(rates) == len(sweep.delays_ms) and all(0 <= r <= 1 for r in rates)


def test_target_levels_send_evenly_spaced_targets_through_the_filter_and_refuse_bad_actions():
    from pendkit.agents.learners import learner
    from pendkit.agents.runs import RunSpec, build_run
    from pendkit.errors import ActionError

    env, agent, inputs = build_run(RunSpec("r-dqn+levels", "ideal"))
    assert env.action_space.n == 9 and inputs.action_dim == 9
    env.reset(seed=0)
    for _ in range(40):  # the rightmost target, held: the filtered command reaches it
        env.step(8)
    assert env.unwrapped._filtered_unit == pytest.approx(1.0, abs=1e-2)
    for bad in (9, -1, 1.5, True, np.array([1, 2])):
        with pytest.raises(ActionError):
            env.step(bad)
    with pytest.raises(ConfigError):
        build_run(RunSpec("r-dqn+levels", "ideal"), pendkit.make(action_mode="continuous"))
    assert learner("r-dqn+levels").wrap(pendkit.make(action_mode="continuous")).action(4)[0] == 0.0
