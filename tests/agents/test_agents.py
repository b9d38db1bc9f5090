"""The agents' building blocks: replay, DQN on a problem with a known answer, the GRU encoder's design,
and the trainer on the twin."""

import csv

import numpy as np
import pytest

torch = pytest.importorskip("torch")

import pendkit  # noqa: E402
from pendkit.agents.dqn import DqnAgent, DqnConfig  # noqa: E402
from pendkit.agents.gru_encoder import GruEncoder  # noqa: E402
from pendkit.agents.inputs import StepInputs  # noqa: E402
from pendkit.agents.replay import ReplayBuffer  # noqa: E402
from pendkit.agents.train import train_sync  # noqa: E402
from pendkit.errors import ConfigError  # noqa: E402


def test_replay_keeps_the_newest_and_round_trips():
    buffer = ReplayBuffer(capacity=3, observation_dim=2, seed=1)
    for k in range(5):
        buffer.add([k, k], k % 2, float(k), [k + 1, k + 1], k == 4)
    assert len(buffer) == 3 and sorted(buffer.rewards.tolist()) == [2.0, 3.0, 4.0]
    batch = buffer.sample(8)
    assert batch.observations.shape == (8, 2) and batch.actions.dtype == torch.int64
    copy = ReplayBuffer(capacity=3, observation_dim=2)
    copy.load_state_dict(buffer.state_dict())
    assert torch.equal(copy.sample(4).rewards, buffer.sample(4).rewards)  # same data, same generator state
    with pytest.raises(ConfigError, match="empty"):
        ReplayBuffer(2, 1).sample(1)


def chain_transitions(length=5):
    """A corridor: action 1 steps right, 0 left; reaching the right end pays 1 and ends the episode."""
    eye = np.eye(length, dtype=np.float32)
    for state in range(length - 1):
        for action in (0, 1):
            nxt = min(state + 1, length - 1) if action == 1 else max(state - 1, 0)
            yield eye[state], action, float(nxt == length - 1), eye[nxt], nxt == length - 1


@pytest.mark.parametrize("double", [True, False])
def test_dqn_learns_the_optimal_policy_of_a_known_problem(double):
    agent = DqnAgent(5, 2, DqnConfig(hidden=(32,), learning_rate=5e-3, gamma=0.9, batch_size=32,
                                     target_update_every=50, double=double, seed=3))
    buffer = ReplayBuffer(1000, 5, seed=3)
    for _ in range(20):
        for transition in chain_transitions():
            buffer.add(*transition)
    for _ in range(1500):
        metrics = agent.update(buffer.sample(32))
    assert np.isfinite(metrics["loss"])
    eye = np.eye(5, dtype=np.float32)
    assert [agent.act(eye[s], explore=False) for s in range(4)] == [1, 1, 1, 1]  # always go right
    q = agent.q(torch.from_numpy(eye[:4])).detach().numpy().max(axis=1)
    np.testing.assert_allclose(q, [0.9**3, 0.9**2, 0.9, 1.0], atol=0.08)  # the true values


def test_epsilon_schedule_and_validation():
    agent = DqnAgent(3, 2, DqnConfig(epsilon_decay_steps=100, epsilon_end=0.1))
    assert agent.epsilon == 1.0
    for _ in range(200):
        agent.act(np.zeros(3))
    assert agent.epsilon == pytest.approx(0.1)
    with pytest.raises(ConfigError, match="gamma"):
        DqnConfig(gamma=1.0)
    with pytest.raises(ConfigError, match="epsilon_end"):
        DqnConfig(epsilon_start=0.1, epsilon_end=0.5)


def test_agent_state_round_trips():
    agent = DqnAgent(4, 3, DqnConfig(seed=5))
    clone = DqnAgent(4, 3, DqnConfig(seed=9))
    clone.load_state_dict(agent.state_dict())
    inputs = np.random.default_rng(0).normal(size=(10, 4)).astype(np.float32)
    assert [agent.act(x, explore=False) for x in inputs] == [clone.act(x, explore=False) for x in inputs]


def test_gru_encoder_is_fixed_and_remembers_the_history():
    encoder = GruEncoder(input_dim=3, hidden_size=8, seed=0)
    before = [p.detach().clone() for p in encoder.cell.parameters()]
    history_a = [np.array([0.1, 0.0, 1.0]), np.array([0.2, 0.5, 0.0])]
    history_b = [np.array([-0.4, 0.3, 0.0]), np.array([0.2, 0.5, 0.0])]  # same last input
    out_a = [encoder.encode(x) for x in history_a][-1]
    encoder.reset()
    out_b = [encoder.encode(x) for x in history_b][-1]
    encoder.reset()
    again = [encoder.encode(x) for x in history_a][-1]
    assert out_a.shape == (encoder.output_dim,) == (11,)
    np.testing.assert_array_equal(out_a[:3], out_b[:3])  # the current input is the same...
    assert not np.allclose(out_a[3:], out_b[3:])  # ...but the encoded history differs
    np.testing.assert_array_equal(out_a, again)  # deterministic
    assert all(torch.equal(p, q) for p, q in zip(before, encoder.cell.parameters()))  # never trained
    assert not any(p.requires_grad for p in encoder.cell.parameters())


def test_trainer_runs_on_the_twin_with_and_without_the_encoder(tmp_path):
    for encoder in (None, GruEncoder(7 + 5, hidden_size=16)):
        env = pendkit.make(fidelity="ideal", max_episode_steps=40)
        input_dim = encoder.output_dim if encoder else 7 + 5
        agent = DqnAgent(input_dim, 5, DqnConfig(learning_starts=50, batch_size=16))
        returns = train_sync(env, agent, episodes=3, inputs=StepInputs.for_env(env, 1, encoder), progress=False,
                             csv_path=tmp_path / "returns.csv")
        assert len(returns) == 3 and all(np.isfinite(returns)) and agent.updates == 3 * 40 - 49
        rows = list(csv.DictReader((tmp_path / "returns.csv").open()))
        assert [float(r["return"]) for r in rows] == pytest.approx(returns, abs=1e-3)
