"""TD3 on a problem with a known answer, and its settings."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from pendkit.agents.replay import ReplayBuffer  # noqa: E402
from pendkit.agents.td3 import Td3Agent, Td3Config  # noqa: E402
from pendkit.errors import ConfigError  # noqa: E402


def learn_the_bandit(agent) -> tuple[dict, np.ndarray, np.ndarray]:
    """Reward -(a - 0.5 s)^2 in one step (the best deterministic policy is a = 0.5 s): 1500 updates from 3000
    random tries; (the last update's metrics, states, the greedy actions at them)."""
    buffer = ReplayBuffer(5000, 1, seed=1, action_dim=1)
    rng = np.random.default_rng(1)
    for _ in range(3000):
        s = rng.uniform(-1, 1, 1).astype(np.float32)
        a = rng.uniform(-1, 1, 1).astype(np.float32)
        buffer.add(s, a, float(-(a[0] - 0.5 * s[0]) ** 2), s, True)
    for _ in range(1500):
        metrics = agent.update(buffer.sample(64))
    states = np.linspace(-0.9, 0.9, 7, dtype=np.float32)
    return metrics, states, np.array([agent.act([s], explore=False)[0] for s in states])


def test_td3_learns_the_best_action_of_a_contextual_bandit():
    metrics, states, actions = learn_the_bandit(Td3Agent(1, 1, Td3Config(hidden=(32, 32), batch_size=64, seed=1)))
    assert "actor_loss" in metrics and np.isfinite(metrics["critic_loss"])
    np.testing.assert_allclose(actions, 0.5 * states, atol=0.1)


def test_td3_actions_stay_in_range_and_state_round_trips():
    agent = Td3Agent(3, 1, Td3Config(exploration_noise=5.0))
    for _ in range(50):
        action = agent.act(np.zeros(3))
        assert action.shape == (1,) and -1 <= action[0] <= 1
    clone = Td3Agent(3, 1, Td3Config(seed=7))
    clone.load_state_dict(agent.state_dict())
    x = np.ones(3, dtype=np.float32)
    np.testing.assert_array_equal(agent.act(x, explore=False), clone.act(x, explore=False))
    with pytest.raises(ConfigError, match="gamma"):
        Td3Config(gamma=1.5)
