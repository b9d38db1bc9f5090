"""Lab 08, delays and the GRU encoder: public tests."""

from __future__ import annotations

import numpy as np

from pendkit.grading.core import Diagnosis, Failed, expect, shown, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

delayed = task("08.delayed_view", function="delayed_view", title="What a delayed agent sees", hidden_points=1)
augmented = task("08.augmented_state", function="augmented_state",
                 title="The augmented state of a delayed rig", hidden_points=1)
gru = task("08.gru_step", function="gru_step", title="One step of a GRU cell", hidden_points=2)
contrast = task("08.breaking_delay", function="breaking_delay", title="Where plain DQN breaks", hidden_points=1)


def _array(got, name, shape):
    try:
        array = np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        raise Failed(f"{name} should return an array of numbers") from None
    expect(array.shape == shape, f"{name} should return shape {shape}, got {array.shape}")
    return array


@delayed.test(points=2, hint="Row t is observation max(0, t - delay): the first rows repeat the first one.")
def shifted_and_padded(fn, rng):
    observations = np.arange(12, dtype=float).reshape(6, 2)
    expected = observations[np.maximum(0, np.arange(6) - 2)]
    got = _array(fn(observations.copy(), 2), "delayed_view(observations, 2)", (6, 2))
    message = f"delayed_view(..., 2) should be {expected.tolist()}, got {got.tolist()}"
    if np.allclose(got, np.roll(observations, 2, axis=0)):
        message += Diagnosis(": np.roll wraps the last rows round to the start; the agent cannot see the future")
    elif np.allclose(got, observations):
        message += Diagnosis(": nothing is delayed")
    else:
        for steps, said in ((1, "one step short"), (3, "one step too many")):
            if np.allclose(got, observations[np.maximum(0, np.arange(6) - steps)]):
                message += Diagnosis(f": that is a delay of {steps}, {said} (row t is observation t - delay)")
    expect(np.allclose(got, expected), message)
    same = _array(fn(observations.copy(), 0), "delayed_view(observations, 0)", (6, 2))
    expect(np.allclose(same, observations), "a delay of 0 should return the observations unchanged")


def _numeric(value) -> bool:
    try:
        np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return False
    return True


def reference_augmented_state(observation, recent_actions, n_actions):
    codes = np.zeros((len(recent_actions), n_actions))
    codes[np.arange(len(recent_actions)), list(recent_actions)] = 1.0
    return np.concatenate([np.asarray(observation, dtype=float).ravel(), codes.ravel()])


@augmented.test(points=3, hint="The observation, then one one-hot code per recent action, newest first "
                                "(recent_actions is newest first already).")
def observation_then_one_hot_actions(fn, rng):
    observation, recent = np.array([0.5, -1.0, 2.0]), [4, 0, 2]
    expected = reference_augmented_state(observation, recent, 5)
    call = "augmented_state([0.5, -1, 2], [4, 0, 2], 5)"
    raw = fn(observation.copy(), list(recent), 5)
    flat = np.asarray(raw, dtype=float).ravel() if _numeric(raw) else None
    if flat is not None and flat.shape == (6,) and np.allclose(flat, [0.5, -1.0, 2.0, *recent]):
        raise Failed(f"{call} should have 18 values: use one-hot codes, not the action numbers (action 4 is not "
                     "'twice' action 2)")
    got = _array(raw, call, (18,)).copy()
    fn(observation.copy(), [1, 3, 0], 5)  # other actions in between: a buffer kept between calls shows now
    again = _array(fn(observation.copy(), list(recent), 5), call, (18,))
    expect(np.allclose(again, got), f"{call} gave a different answer the second time: something is shared between "
                                    "calls (an array made once and filled again, or the input changed in place)")
    if np.allclose(got, reference_augmented_state(observation, recent[::-1], 5)):
        raise Failed(f"{call}: the actions are in the wrong order; keep recent_actions as given, newest first")
    parts = []
    if not np.allclose(got[:3], expected[:3]):
        parts.append(f"the observation part should be {expected[:3].tolist()}, got {np.round(got[:3], 6).tolist()}")
    ones_wanted, ones_got = np.flatnonzero(expected[3:] == 1).tolist(), np.flatnonzero(got[3:] != 0).tolist()
    if ones_wanted != ones_got or not np.allclose(got[3:], expected[3:]):
        parts.append(f"after it, one 1 per action in blocks of 5: 1s at {ones_wanted}, got non-zeros at {ones_got}")
    expect(not parts, f"{call}: " + "; ".join(parts))
    single = _array(fn(np.zeros(2), [1], 3), "augmented_state([0, 0], [1], 3)", (5,))
    expect(np.allclose(single, [0, 0, 0, 1, 0]), f"augmented_state([0, 0], [1], 3) should be [0, 0, 0, 1, 0], "
                                                 f"got {single.tolist()}")


def reference_gru_step(x, h, w_ih, w_hh, b_ih, b_hh, variant: str = ""):
    """PyTorch's GRUCell, gates stacked (reset, update, new); `variant` names one of the known wrong cells."""
    gi, gh = w_ih @ x + b_ih, w_hh @ h + b_hh
    size = len(h)
    sigmoid = lambda v: 1 / (1 + np.exp(-v))  # noqa: E731
    reset = sigmoid(gi[:size] + gh[:size])
    update = sigmoid(gi[size:2 * size] + gh[size:2 * size])
    if variant == "update first":
        reset, update = update, reset
    if variant == "b_hn outside":
        new = np.tanh(gi[2 * size:] + reset * (w_hh[2 * size:] @ h) + b_hh[2 * size:])
    elif variant == "reset on h":
        new = np.tanh(gi[2 * size:] + w_hh[2 * size:] @ (reset * h) + b_hh[2 * size:])
    elif variant == "no reset":
        new = np.tanh(gi[2 * size:] + gh[2 * size:])
    else:
        new = np.tanh(gi[2 * size:] + reset * gh[2 * size:])
    if variant == "z swapped":
        return update * new + (1 - update) * h
    return (1 - update) * new + update * h


GRU_MISTAKES = {
    "z swapped": ": z and (1 - z) are swapped; z keeps the old state: h' = (1 - z) n + z h",
    "b_hn outside": ": b_hn is added outside the reset gate; PyTorch's cell scales both, r (W_hn h + b_hn)",
    "update first": ": the gates are taken in the order (update, reset); each weight and bias stacks them (reset, "
                    "update, new): rows 0..H-1 are the reset gate's",
    "reset on h": ": the reset gate multiplies h before W_hn (the original paper's cell); PyTorch's scales the "
                  "product, r (W_hn h + b_hn)",
    "no reset": ": the reset gate is left out of the new gate: n = tanh(W_in x + b_in + r (W_hn h + b_hn))",
}


def gru_note(got, x, h, w_ih, w_hh, b_ih, b_hh) -> str:
    """The cause of a wrong GRU step, when `got` is one of the known wrong cells (a `Diagnosis`), else ""."""
    got = np.asarray(got, dtype=float)
    for variant, cause in GRU_MISTAKES.items():
        wrong = reference_gru_step(x, h, w_ih, w_hh, b_ih, b_hh, variant)
        if got.shape == wrong.shape and np.allclose(got, wrong, atol=1e-9):
            return Diagnosis(cause)
    return ""


@gru.test(points=3, hint="Gates stacked (reset, update, new); h' = (1 - z) n + z h; the reset gate scales "
                         "W_hn h + b_hn.")
def matches_the_equations(fn, rng):
    inputs, size = 3, 4
    x, h = rng.normal(size=inputs), rng.normal(size=size)
    w_ih, w_hh = rng.normal(size=(3 * size, inputs)), rng.normal(size=(3 * size, size))
    b_ih, b_hh = rng.normal(size=3 * size), rng.normal(size=3 * size)
    expected = reference_gru_step(x, h, w_ih, w_hh, b_ih, b_hh)
    got = _array(fn(x, h, w_ih, w_hh, b_ih, b_hh), "gru_step(...)", (size,))
    message = f"gru_step should give {np.round(expected, 4).tolist()}, got {np.round(got, 4).tolist()}"
    expect(np.allclose(got, expected, atol=1e-9), message + gru_note(got, x, h, w_ih, w_hh, b_ih, b_hh))


@contrast.test(points=2, hint="The first delay (in the given order) where plain < threshold <= other; "
                              "None if there is none.")
def first_contrast(fn, rng):
    delays = [0, 30, 60, 90, 120]
    plain = [1.0, 0.9, 0.4, 0.0, 0.1]
    other = [1.0, 0.9, 0.8, 0.3, 0.1]
    got = fn(delays, plain, other, 0.5)
    message = f"with plain_rates {plain} and other_rates {other}, expected 60, got {shown(got)}"
    if got == 90:
        message += ": that is where plain is worst; the question is where it first breaks"
    expect(got == 60, message)
    expect(fn(delays, plain, [0.2] * 5, 0.5) is None,
           "when the other agent (other_rates) also fails, there is no contrast: return None")
    expect(fn(delays, [1.0] * 5, other, 0.5) is None, "when plain DQN never breaks, return None")
    # the boundaries: exactly at the threshold, plain has not broken and the other agent holds
    at_threshold = fn([0, 60, 120], [1.0, 0.5, 0.0], [1.0, 0.5, 0.5], 0.5)
    expect(at_threshold == 120, f"plain at exactly the threshold (0.5 at 60 ms) has not broken yet, and the other "
                                f"agent at exactly the threshold holds: expected 120, got {shown(at_threshold)} "
                                "(plain < threshold, not <=; other >= threshold, not >)")


prelab_task("08", ("gru_input_weights", "delay_steps"))

written("08.reflection", "Reflection", points=3)
