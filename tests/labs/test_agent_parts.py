"""Labs 07 and 08's hooks (`pendkit.labs.agent_parts`): a student's epsilon, TD target and loss run inside
the kit's DQN; right ones reproduce the built-in agent, wrong ones change what it learns, broken ones give
a message that says what is wrong."""

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from pendkit.agents.dqn import DqnAgent, DqnConfig  # noqa: E402
from pendkit.agents.replay import ReplayBuffer  # noqa: E402
from pendkit.labs.agent_parts import (  # noqa: E402
    StudentCodeError,
    StudentParts,
    curve_against_myopic,
    student_dqn,
)


def epsilon(step, start, end, decay_steps):
    return start + min(1.0, step / decay_steps) * (end - start)


def td_target(rewards, dones, next_q_online, next_q_target, gamma, double):
    if double:
        next_value = next_q_target[np.arange(len(rewards)), next_q_online.argmax(axis=1)]
    else:
        next_value = next_q_target.max(axis=1)
    return rewards + gamma * (1 - dones) * next_value


def huber(errors, delta):
    e = np.abs(errors)
    return np.where(e <= delta, 0.5 * e**2, delta * (e - 0.5 * delta))


def batch_of(size=64, seed=0):
    rng = np.random.default_rng(seed)
    buffer = ReplayBuffer(500, 4, seed)
    for _ in range(500):
        buffer.add(rng.normal(size=4), int(rng.integers(3)), float(rng.normal()), rng.normal(size=4),
                   bool(rng.random() < 0.1))
    return buffer.sample(size)


@pytest.mark.parametrize("double", [True, False])
def test_right_parts_train_exactly_like_the_built_in_agent(double):
    config = DqnConfig(seed=5, double=double, huber_delta=0.5)
    built_in, student = DqnAgent(4, 3, config), student_dqn(4, 3, config, StudentParts(epsilon, td_target, huber))
    for k in range(20):
        batch = batch_of(seed=k)
        a, b = built_in.update(batch), student.update(batch)
        assert b["loss"] == pytest.approx(a["loss"], rel=1e-4)
    for p, q in zip(built_in.q.parameters(), student.q.parameters()):
        torch.testing.assert_close(p, q, atol=2e-5, rtol=1e-4)
    for steps in (0, 5000, 20_000):
        built_in.steps = student.steps = steps
        assert student.epsilon == pytest.approx(built_in.epsilon)


def test_a_wrong_target_changes_the_learning():
    def forgets_gamma(rewards, dones, next_q_online, next_q_target, gamma, double):
        return rewards + (1 - dones) * next_q_target.max(axis=1)

    config = DqnConfig(seed=5)
    right, wrong = student_dqn(4, 3, config, StudentParts(td_target=td_target)), \
        student_dqn(4, 3, config, StudentParts(td_target=forgets_gamma))
    for k in range(20):
        right.update(batch_of(seed=k)), wrong.update(batch_of(seed=k))
    gap = max(float((p - q).detach().abs().max()) for p, q in zip(right.q.parameters(), wrong.q.parameters()))
    assert gap > 1e-3


def test_broken_parts_say_what_is_wrong():
    batch = batch_of()
    with pytest.raises(StudentCodeError, match=r"shape \(64, 1\)"):
        student_dqn(4, 3, parts=StudentParts(td_target=lambda r, d, o, t, g, dbl: r[:, None])).update(batch)
    with pytest.raises(StudentCodeError, match="non-finite"):
        with np.errstate(divide="ignore"):
            student_dqn(4, 3, parts=StudentParts(td_target=lambda r, d, o, t, g, dbl: r / 0.0)).update(batch)
    with pytest.raises(StudentCodeError, match="elementwise"):
        student_dqn(4, 3, parts=StudentParts(loss=lambda e, delta: float(np.mean(e**2)))).update(batch)
    with pytest.raises(StudentCodeError, match=r"\[0, 1\]"):
        student_dqn(4, 3, parts=StudentParts(epsilon=lambda s, a, b, n: 2.0)).act(np.zeros(4))
    with pytest.raises(StudentCodeError, match="raised"):
        student_dqn(4, 3, parts=StudentParts(loss=lambda e, delta: undefined_name)).update(batch)  # noqa: F821
    with pytest.raises(StudentCodeError, match="over axis=1"):  # the max over the batch, not the actions
        student_dqn(4, 3, parts=StudentParts(td_target=lambda r, d, o, t, g, dbl: r + g * t.max(axis=0))).update(batch)


def test_a_curve_below_the_myopic_one_is_named_and_a_learning_one_is_not():
    myopic = np.full(40, -2000.0)
    sign_slip = np.linspace(-2000, -4500, 40)  # what a target with the future's sign reversed did in the lab
    assert "below the one with no future" in curve_against_myopic(sign_slip, myopic)
    assert "the myopic one, episode for episode" in curve_against_myopic(myopic, myopic)
    assert curve_against_myopic(np.linspace(-2000, -600, 40), myopic) is None
    assert curve_against_myopic(myopic - 50, myopic) is None  # noise, not a sign slip


@pytest.mark.expensive
def test_in_the_labs_budget_a_wrong_target_visibly_fails_to_learn():
    """Lab 07's invert check: the student's target drives the curve they see. Trained as the lab's cell
    trains (ideal twin, seed 0, one torch thread), the right target's returns rise; a myopic one (the
    reward alone, no future) stays where a random policy is. (A target that forgets gamma still learns
    something in 50 episodes: measured -1454 against -1367 for the right one, so it is not asserted.)"""
    import pendkit
    from pendkit.labs.agent_parts import train_with_parts

    def myopic(rewards, dones, next_q_online, next_q_target, gamma, double):
        return rewards

    late = {}
    for name, target in (("right", td_target), ("myopic", myopic)):
        env = pendkit.make(fidelity="ideal")
        _, returns = train_with_parts(env, StudentParts(epsilon, target, huber), LAB_EPISODES, seed=0)
        late[name] = float(np.mean(returns[-10:]))
    assert late["right"] > late["myopic"] + 500, late


LAB_EPISODES = 50


def test_a_students_augmented_state_is_what_the_delay_aware_agent_sees():
    import gymnasium as gym

    from pendkit.agents.inputs import StepInputs
    from pendkit.labs.agent_parts import StudentInputs

    def right(observation, recent, n):
        return np.concatenate([observation, np.eye(n)[recent].ravel()])

    def oldest_first(observation, recent, n):
        return right(observation, recent[::-1], n)

    rng = np.random.default_rng(0)
    kit, mine, wrong = StepInputs(3, gym.spaces.Discrete(5), 3), StudentInputs(right, 3, 5, 3), \
        StudentInputs(oldest_first, 3, 5, 3)
    observation = rng.normal(size=3).astype(np.float32)
    xs = [(kit.reset(observation), mine.reset(observation), wrong.reset(observation))]
    for _ in range(10):
        observation, action = rng.normal(size=3).astype(np.float32), int(rng.integers(5))
        xs.append((kit.step(observation, action), mine.step(observation, action), wrong.step(observation, action)))
    assert all(np.array_equal(a, b) for a, b, _ in xs)  # a right answer trains exactly the kit's dqn+actions
    assert any(not np.array_equal(a, c) for a, _, c in xs)  # a wrong one feeds the agent something else
    with pytest.raises(StudentCodeError, match="expected \\(18,\\)"):
        StudentInputs(lambda o, r, n: o, 3, 5, 3).reset(observation)


def test_lab08_states_the_delay_range_its_sweep_file_holds():
    import re
    from pathlib import Path

    import nbformat

    from pendkit.agents.results import delay_sweep

    root = Path(__file__).resolve().parents[2]
    text = " ".join(c.source for c in nbformat.read(root / "solutions" / "08_gru_rdqn.ipynb", as_version=4).cells)
    stated = [int(m) for m in re.findall(r"from 0 to (\d+) ms", text)]
    assert stated and all(ms == delay_sweep().delays_ms[-1] for ms in stated), stated
