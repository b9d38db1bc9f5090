"""SAC on a problem with a known answer, its settings, and its place among the learners."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from pendkit.agents.sac import SacAgent, SacConfig  # noqa: E402
from pendkit.errors import ConfigError  # noqa: E402
from tests.agents.test_td3 import learn_the_bandit  # noqa: E402


def test_sac_learns_the_best_action_of_a_contextual_bandit():
    # the greedy action is tanh of the actor's mean
    metrics, states, actions = learn_the_bandit(SacAgent(1, 1, SacConfig(hidden=(32, 32), batch_size=64, seed=1)))
    assert np.isfinite(metrics["critic_loss"]) and metrics["temperature"] < 1.0  # tuned down from 1
    np.testing.assert_allclose(actions, 0.5 * states, atol=0.1)


def test_sac_explores_in_range_acts_greedily_the_same_twice_and_round_trips():
    agent = SacAgent(3, 1)
    drawn = np.array([agent.act(np.zeros(3))[0] for _ in range(200)])
    assert np.all(np.abs(drawn) <= 1) and drawn.std() > 0.1  # a wide policy before learning
    x = np.ones(3, dtype=np.float32)
    assert np.array_equal(agent.act(x, explore=False), agent.act(x, explore=False))
    clone = SacAgent(3, 1, SacConfig(seed=7))
    clone.load_state_dict(agent.state_dict())
    np.testing.assert_array_equal(agent.act(x, explore=False), clone.act(x, explore=False))
    np.testing.assert_array_equal(agent.act(x), clone.act(x))  # the exploration stream is restored too
    with pytest.raises(ConfigError, match="tau"):
        SacConfig(tau=0.0)


def test_sac_is_a_learner_on_the_continuous_env_and_saves_as_data(tmp_path):
    import pendkit
    from pendkit.agents.learners import build_learner, learner
    from pendkit.agents.runs import RunSpec, load_weights, save_weights

    env = pendkit.make(fidelity="ideal", **learner("sac+estimated").env_kwargs())
    agent, inputs = build_learner("sac+estimated", env, seed=3)
    observation, _ = env.reset(seed=0)
    action = agent.act(inputs.reset(observation), explore=False)
    assert env.action_space.contains(action)
    save_weights(tmp_path / "sac.pt", agent, RunSpec("sac+estimated", "ideal", seed=3), {})
    spec, state = load_weights(tmp_path / "sac.pt")
    assert spec.learner == "sac+estimated"
    again, _ = build_learner("sac+estimated", env, seed=9)
    again.load_state_dict(state)
    x = inputs.reset(observation)
    np.testing.assert_array_equal(agent.act(x, explore=False), again.act(x, explore=False))
