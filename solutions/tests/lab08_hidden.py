"""Hidden tests for lab 08 (instructor material: never copied into labs/)."""

import numpy as np
import torch

from pendkit.grading import expect, task
from pendkit.grading.core import shown
from pendkit.grading.prelab import prelab_answers

gru = task("08.gru_step", function="gru_step", title="One step of a GRU cell")
augmented = task("08.augmented_state", function="augmented_state", title="The augmented state of a delayed rig")
delayed = task("08.delayed_view", function="delayed_view", title="What a delayed agent sees")


@gru.test(points=2, hidden=True, hint="It must agree with torch.nn.GRUCell, the cell pendkit's encoder uses.")
def matches_torch(fn, rng):
    cell = torch.nn.GRUCell(5, 6).double()
    x, h = rng.normal(size=5), rng.normal(size=6)
    with torch.no_grad():
        expected = cell(torch.tensor(x)[None], torch.tensor(h)[None])[0].numpy()
    weights = [p.detach().numpy() for p in (cell.weight_ih, cell.weight_hh, cell.bias_ih, cell.bias_hh)]
    expect(np.allclose(np.asarray(fn(x, h, *weights), dtype=float), expected), "differs from torch.nn.GRUCell")


@delayed.test(points=1, hidden=True, hint="A delay longer than the episode shows only the first observation.")
def longer_than_the_episode(fn, rng):
    observations = rng.normal(size=(4, 3))
    got = np.asarray(fn(observations, 10), dtype=float)
    expect(np.allclose(got, np.repeat(observations[:1], 4, axis=0)), "every row should be the first observation")


@augmented.test(points=1, hidden=True, hint="It must agree with the kit's delay-aware input for any delay.")
def matches_the_kit(fn, rng):
    import gymnasium as gym

    from pendkit.agents.inputs import StepInputs

    for seen in (1, 3, 6):
        inputs = StepInputs(4, gym.spaces.Discrete(5), actions_seen=seen)
        observation = rng.normal(size=4)
        x, recent = inputs.reset(observation), [0] * seen
        for _ in range(8):
            action = int(rng.integers(5))
            recent = [action, *recent[:-1]]
            observation = rng.normal(size=4)
            x = inputs.step(observation, action)
        got = np.asarray(fn(observation.astype(np.float32), list(recent), 5), dtype=float)
        expect(got.shape == x.shape and np.allclose(got, x, atol=1e-6), f"differs from the kit with {seen} actions")


contrast = task("08.breaking_delay", function="breaking_delay", title="Where plain DQN breaks")


@contrast.test(points=1, hidden=True, hint="Any sweep: the first delay where plain < threshold <= the other.")
def random_sweeps(fn, rng):
    for _ in range(20):
        n = int(rng.integers(2, 8))
        delays = sorted(rng.choice(np.arange(0, 400, 20), n, replace=False).tolist())
        plain, other = rng.random(n).round(2).tolist(), rng.random(n).round(2).tolist()
        threshold = float(rng.choice([0.5, 0.8]))
        want = next((d for d, p, o in zip(delays, plain, other) if p < threshold <= o), None)
        got = fn(delays, plain, other, threshold)
        expect(got == want,
               f"breaking_delay({delays}, {plain}, {other}, {threshold}) should be {want}, got {shown(got)}")


prelab_answers("08", {"gru_input_weights": 1152, "delay_steps": 4},
               where="Each question gives what it needs: the GRU's three blocks of weights are in the question "
                     "(and in Task 3).")
