"""Hidden tests for lab 08 (instructor material: never copied into labs/)."""

import numpy as np
import torch

from pendkit.grading import expect, task
from pendkit.grading.core import shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab08 import gru_note, reference_gru_step

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
    got = np.asarray(fn(x, h, *weights), dtype=float)
    expect(got.shape == expected.shape and np.allclose(got, expected),
           f"a torch.nn.GRUCell(5, 6) gives {np.round(expected, 4).tolist()}, your gru_step on its weights "
           f"{np.round(got, 4).tolist()}" + gru_note(got, x, h, *weights))


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


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def shared_buffer_augmented_state():
    """The aliasing bug: one array for the codes, made once and filled again on every call."""
    buffer = {}

    def augmented(observation, recent, n):
        codes = buffer.setdefault((len(recent), n), np.zeros((len(recent), n)))
        codes[np.arange(len(recent)), list(recent)] = 1.0
        return np.concatenate([np.asarray(observation, dtype=float).ravel(), codes.ravel()])

    return augmented


def augmented_state(observation, recent, n, oldest_first=False, one_hot=True):
    recent = list(recent)[::-1] if oldest_first else list(recent)
    codes = np.eye(n)[recent].ravel() if one_hot else np.asarray(recent, dtype=float)
    return np.concatenate([np.asarray(observation, dtype=float).ravel(), codes])


def gru_step(x, h, w_ih, w_hh, b_ih, b_hh, variant=""):
    return reference_gru_step(np.asarray(x, float), np.asarray(h, float), w_ih, w_hh, b_ih, b_hh, variant)


CORRECT = {
    "08.delayed_view": lambda obs, k: np.asarray(obs)[np.maximum(0, np.arange(len(obs)) - k)],
    "08.gru_step": lambda x, h, w_ih, w_hh, b_ih, b_hh: gru_step(x, h, w_ih, w_hh, b_ih, b_hh),
    "08.augmented_state": lambda obs, recent, n: augmented_state(obs, recent, n),
    "08.breaking_delay": lambda d, p, r, t=0.5: next((a for a, b, c in zip(d, p, r) if b < t <= c), None),
}

MISTAKES = [
    ("08.delayed_view", lambda obs, k: np.roll(obs, k, axis=0), "np.roll"),
    ("08.delayed_view", lambda obs, k: np.asarray(obs), "nothing is delayed"),
    ("08.delayed_view", lambda obs, k: np.asarray(obs)[np.clip(np.arange(len(obs)) - k + 1, 0, len(obs) - 1)],
     "one step short", {"shifted_and_padded"}),
    ("08.gru_step", lambda x, h, a, b, c, d: gru_step(x, h, a, b, c, d, "z swapped"), "z and (1 - z) are swapped",
     {"matches_the_equations", "matches_torch"}),
    ("08.gru_step", lambda x, h, a, b, c, d: gru_step(x, h, a, b, c, d, "b_hn outside"), "b_hn is added outside",
     {"matches_the_equations", "matches_torch"}),
    ("08.gru_step", lambda x, h, a, b, c, d: gru_step(x, h, a, b, c, d, "update first"), "order (update, reset)",
     {"matches_the_equations", "matches_torch"}),
    ("08.gru_step", lambda x, h, a, b, c, d: gru_step(x, h, a, b, c, d, "reset on h"), "multiplies h before W_hn",
     {"matches_the_equations", "matches_torch"}),
    ("08.augmented_state", lambda o, r, n: augmented_state(o, r, n, oldest_first=True), "wrong order"),
    ("08.augmented_state", lambda o, r, n: augmented_state(o, r, n, one_hot=False), "one-hot codes"),
    ("08.breaking_delay", lambda d, p, r, t=0.5: d[int(np.argmin(p))], "first breaks"),
    ("08.breaking_delay", lambda d, p, r, t=0.5: next((x for x, a, b in zip(d, p, r) if a <= t <= b), None),
     "not <="),
    ("08.breaking_delay", lambda d, p, r, t=0.5: next((x for x, a, b in zip(d, p, r) if a < t < b), None), "not >"),
    ("08.augmented_state", shared_buffer_augmented_state(), "shared between calls"),
    ("08.breaking_delay", lambda d, p, r, t=0.5: next((x for x, a in zip(d, p) if a < t), None),
     "the other agent (other_rates) also fails"),
]
