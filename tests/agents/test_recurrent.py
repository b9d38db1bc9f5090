"""The trained recurrent agents and their replay: stretches re-encoded from stored state, a memory task
that only an agent with a trained memory solves, normalisation kept in checkpoints."""

import gymnasium as gym
import numpy as np
import pytest

torch = pytest.importorskip("torch")

from pendkit.agents.dqn import DqnAgent, DqnConfig  # noqa: E402
from pendkit.agents.inputs import StepInputs  # noqa: E402
from pendkit.agents.normalizer import RunningNormalizer  # noqa: E402
from pendkit.agents.recurrent_dqn import RecurrentDqnAgent, RecurrentDqnConfig  # noqa: E402
from pendkit.agents.recurrent_td3 import RecurrentTd3Agent, RecurrentTd3Config  # noqa: E402
from pendkit.agents.sequence_replay import SequenceReplay  # noqa: E402
from pendkit.agents.train import agent_episode, train_sync  # noqa: E402


class CueRecall(gym.Env):
    """A cue (+1 or -1) shows on the first step only; on the last of 5 steps the agent must answer it
    (discrete: action 1 for +1, 0 for -1, paying +-1; continuous: an action near the cue, paying
    -(action - cue)^2). Nothing else pays."""

    def __init__(self, continuous=False, steps=5):
        self.steps, self.continuous = steps, continuous
        self.observation_space = gym.spaces.Box(-1, 1, (2,), np.float32)
        self.action_space = gym.spaces.Box(-1, 1, (1,), np.float32) if continuous else gym.spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.cue, self.t = float(self.np_random.choice([-1.0, 1.0])), 0
        return np.array([self.cue, 1.0], np.float32), {}

    def step(self, action):
        self.t += 1
        last = self.t == self.steps
        reward = 0.0
        correct = False
        if last and self.continuous:
            value = float(np.asarray(action).reshape(-1)[0])
            reward, correct = -(value - self.cue) ** 2, np.sign(value) == self.cue
        elif last:
            correct = 2.0 * action - 1.0 == self.cue
            reward = 1.0 if correct else -1.0
        return np.zeros(2, np.float32), reward, last, False, {"correct": correct}


def recall_rate(env, agent, inputs, episodes=40):
    right = 0
    for k in range(episodes):
        _, infos = agent_episode(env, agent, inputs, seed=10_000 + k, explore=False)
        right += infos[-1]["correct"]
    return right / episodes


def test_sequence_replay_stretches_follow_one_episode_even_when_actors_interleave():
    buffer = SequenceReplay(capacity=64, input_dim=1, hidden_dim=2, burn_in=2, length=3, seed=0)
    for t in range(20):  # two actors' steps alternate in the buffer
        for actor in (0, 1):
            buffer.add([100 * actor + t], 0, 0.0, [100 * actor + t + 1], False, hidden=[actor, t],
                       episode=actor, step=t)
    batch = buffer.sample(200)
    inputs, mask, starts = batch.inputs[..., 0], batch.loss_mask.bool(), batch.starts
    for row in range(200):
        last = inputs[row, -1]
        expected = last - torch.arange(4, -1, -1)
        kept = mask[row]
        assert torch.equal(inputs[row][kept], expected[kept])  # every trained step is this episode's own
        assert not kept[:2].any()  # the burn-in is never trained on
        first = int(torch.nonzero(starts[row]).max())  # the state is taken where the episode's run begins
        assert torch.equal(inputs[row, first:], expected[first:])


def test_sequence_replay_masks_across_an_episode_start_and_a_wrapped_buffer():
    buffer = SequenceReplay(capacity=7, input_dim=1, hidden_dim=1, burn_in=1, length=3, seed=1)
    for episode, steps in ((0, 5), (1, 5)):  # 10 steps into 7 rows: wraps
        for t in range(steps):
            buffer.add([10 * episode + t], 0, 0.0, [0], t == steps - 1, hidden=[t], episode=episode, step=t)
    batch = buffer.sample(300)
    for row in range(300):
        values = batch.inputs[row, :, 0]
        kept = batch.loss_mask[row].bool()
        episode_of_last = int(values[-1]) // 10
        assert all(int(v) // 10 == episode_of_last for v in values[kept])
        assert all(int(v) >= 0 for v in values)  # nothing unwritten or overwritten


def test_normalizer_matches_numpy_and_round_trips():
    data = np.random.default_rng(0).normal([3.0, -50.0, 0.0], [0.1, 20.0, 1.0], size=(500, 3))
    norm = RunningNormalizer(3)
    for row in data:
        norm.update(row)
    np.testing.assert_allclose(norm.mean, data.mean(axis=0), rtol=1e-9)
    np.testing.assert_allclose(norm.std, data.std(axis=0, ddof=1), rtol=1e-9)
    z = norm.normalize(torch.tensor([[3.0, 1e6, 0.0]]))
    assert abs(float(z[0, 0])) < 0.2 and float(z[0, 1]) == 5.0  # an outlier is clipped
    copy = RunningNormalizer(3)
    copy.load_state_dict(norm.state_dict())
    assert torch.equal(copy.normalize(torch.ones(1, 3)), norm.normalize(torch.ones(1, 3)))


@pytest.mark.expensive  # the full tier: training
def test_trained_r_dqn_recalls_a_cue_that_plain_dqn_cannot():
    env = CueRecall()
    inputs = StepInputs.for_env(env)
    config = dict(hidden=(32,), gru_size=16, burn_in=2, sequence_length=5, batch_size=32, learning_starts=100,
                  update_every=1, target_update_every=50, epsilon_decay_steps=1500, gamma=0.9, learning_rate=3e-3)
    recurrent = RecurrentDqnAgent(inputs.dim, 2, RecurrentDqnConfig(seed=1, **config))
    train_sync(env, recurrent, 500, inputs, seed=1, progress=False)
    plain = DqnAgent(inputs.dim, 2, DqnConfig(hidden=(32,), batch_size=32, learning_starts=100, gamma=0.9,
                                              epsilon_decay_steps=1500, seed=1))
    train_sync(env, plain, 500, StepInputs.for_env(env), seed=1, progress=False)
    assert recall_rate(env, recurrent, inputs) >= 0.95
    assert recall_rate(env, plain, StepInputs.for_env(env)) <= 0.75  # a memoryless agent can only guess


@pytest.mark.expensive  # the full tier: training
def test_trained_r_td3_recalls_a_cue():
    env = CueRecall(continuous=True)
    inputs = StepInputs.for_env(env)
    agent = RecurrentTd3Agent(inputs.dim, 1, RecurrentTd3Config(
        hidden=(32,), gru_size=16, burn_in=2, sequence_length=5, batch_size=32, learning_starts=100,
        update_every=1, gamma=0.9, exploration_noise=0.3, seed=2))
    train_sync(env, agent, 400, inputs, seed=2, progress=False)
    assert recall_rate(env, agent, inputs) >= 0.95


def test_recurrent_checkpoint_keeps_weights_normalisation_and_replay(tmp_path):
    from pendkit.agents.checkpoint import load_checkpoint, save_checkpoint

    env = CueRecall()
    inputs = StepInputs.for_env(env)
    agent = RecurrentDqnAgent(inputs.dim, 2, RecurrentDqnConfig(learning_starts=10, batch_size=8, seed=4))
    buffer = agent.new_buffer(seed=4)
    train_sync(env, agent, 6, inputs, buffer, seed=4, progress=False)
    save_checkpoint(tmp_path / "c.pt", agent, buffer, 6, [0.0], {})
    other = RecurrentDqnAgent(inputs.dim, 2, RecurrentDqnConfig(learning_starts=10, batch_size=8, seed=9))
    other_buffer = other.new_buffer(seed=9)
    load_checkpoint(tmp_path / "c.pt", other, other_buffer)
    assert other.normalizer.count == agent.normalizer.count > 0
    x = np.array([1.0, 1.0, 1.0, 0.0], np.float32)
    agent.reset(), other.reset()
    assert agent.act(x, explore=False) == other.act(x, explore=False)
    assert torch.equal(other.hidden, agent.hidden)
    assert torch.equal(other_buffer.sample(4).inputs, buffer.sample(4).inputs)


def test_r_dqn_resumed_from_a_checkpoint_is_the_uninterrupted_run(tmp_path):
    import pendkit
    from pendkit.agents.learners import build_learner

    def fresh():
        env = pendkit.make(fidelity="realistic", max_episode_steps=40)
        agent, inputs = build_learner("r-dqn", env, seed=2, learning_starts=30, batch_size=8)
        return env, agent, inputs

    env, agent, inputs = fresh()
    straight = train_sync(env, agent, 4, inputs, seed=2, progress=False)
    env, agent, inputs = fresh()
    train_sync(env, agent, 2, inputs, seed=2, progress=False, checkpoint_path=tmp_path / "c.pt", checkpoint_every=2)
    env, agent, inputs = fresh()
    resumed = train_sync(env, agent, 4, inputs, seed=2, progress=False, checkpoint_path=tmp_path / "c.pt",
                         resume=True)
    assert resumed == pytest.approx(straight, abs=1e-6)
