"""Lab 08's pieces inside the kit: the student's delayed_view is the delay the agents learn behind, and the
student's gru_step is the cell a shipped R-DQN acts through; right pieces change nothing, wrong ones show."""

import numpy as np
import pytest

import pendkit
from pendkit.labs.agent_parts import StudentCodeError
from pendkit.labs.delay_parts import StudentDelay, policy_with_cell
from pendkit.sim.observation_delay import ObservationDelay


def right_view(observations, delay_steps):
    return np.asarray(observations)[np.maximum(0, np.arange(len(observations)) - delay_steps)]


def no_delay(observations, delay_steps):
    return np.asarray(observations)


def seen(env, steps=40):
    rng = np.random.default_rng(1)
    observation, _ = env.reset(seed=4, options={"start": "random"})
    rows = [observation]
    for _ in range(steps):
        rows.append(env.step(int(rng.integers(5)))[0])
    return np.array(rows)


def test_a_right_delayed_view_is_the_kits_delay_and_a_wrong_one_is_not():
    kit = seen(ObservationDelay(pendkit.make(fidelity="ideal"), 2))
    assert np.array_equal(seen(StudentDelay(pendkit.make(fidelity="ideal"), right_view, 2)), kit)
    assert not np.allclose(seen(StudentDelay(pendkit.make(fidelity="ideal"), no_delay, 2)), kit)
    env = StudentDelay(pendkit.make(fidelity="ideal"), right_view, 2)
    assert env.delay_steps == 2  # a delay-aware agent sizes its inputs from it


@pytest.mark.parametrize("view, message", [
    (lambda observations, d: np.asarray(observations)[d:], "returned shape"),
    (lambda observations, d: 1 / 0, "your delayed_view raised ZeroDivisionError"),
])
def test_a_broken_delayed_view_is_named(view, message):
    with pytest.raises(StudentCodeError, match=message):
        seen(StudentDelay(pendkit.make(fidelity="ideal"), view, 2), steps=3)


def gru_cell(gates_swapped: bool):
    """A numpy GRU step in PyTorch's layout; `gates_swapped` reads the reset gate's rows as the update's."""
    def step(x, h, w_ih, w_hh, b_ih, b_hh):
        size = len(h)
        a, b = w_ih @ x + b_ih, w_hh @ h + b_hh
        first = 1 / (1 + np.exp(-(a[:size] + b[:size])))
        second = 1 / (1 + np.exp(-(a[size:2 * size] + b[size:2 * size])))
        reset, update = (second, first) if gates_swapped else (first, second)
        new = np.tanh(a[2 * size:] + reset * b[2 * size:])
        return (1 - update) * new + update * h

    return step


right_cell, swapped_gates = gru_cell(False), gru_cell(True)


def angles(cell, steps=150):
    from pendkit.episode import run_episode

    env = pendkit.make(fidelity="realistic", action_mode="continuous", max_episode_steps=steps)
    trace = run_episode(env, policy_with_cell("r-dqn-levels-realistic", env, cell), seed=5, options={"start": "rest"})
    return np.abs(trace.pendulum_from_upright_rad)


def test_the_shipped_policy_acts_the_same_through_a_right_cell_and_otherwise_through_a_wrong_one():
    kit = angles(None)
    assert kit.min() < 0.3  # the kit's own cell swings it up within these 9 s
    assert np.allclose(angles(right_cell), kit, atol=1e-6)
    wrong = angles(swapped_gates)
    assert not np.allclose(wrong, kit, atol=1e-3) and wrong.min() > 0.3


def test_a_cell_of_the_wrong_shape_is_named():
    with pytest.raises(StudentCodeError, match="your gru_step returned"):
        angles(lambda x, h, *weights: h[:-1], steps=3)
