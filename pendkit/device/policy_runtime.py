"""The device's controller runtime in numpy float32, as the firmware's portable core runs it: a network
(normalise, GRU cell, dense layers, argmax or the raw output) or state feedback, from a parsed blob.
State lives in preallocated arrays (the firmware allocates nothing after start-up either)."""

from __future__ import annotations

import numpy as np

from pendkit.device.controller_blob import NetworkBlob, StateFeedbackBlob
from pendkit.device.observation import observation_to_state
from pendkit.features import resolve_features

F32 = np.float32


def _sigmoid(x: np.ndarray) -> np.ndarray:
    return (F32(1) / (F32(1) + np.exp(-x))).astype(F32)


ACTIVATE = {"none": lambda x: x, "relu": lambda x: np.maximum(x, F32(0)), "tanh": lambda x: np.tanh(x),
            "sigmoid": _sigmoid}


class NetworkRuntime:
    """`reset()` at an episode's start; `step(x)` -> (outputs, action): the action is the argmax, or the
    first output for a continuous network."""

    def __init__(self, blob: NetworkBlob) -> None:
        self.blob = blob
        self.hidden = np.zeros(blob.gru_size, dtype=F32)

    def reset(self) -> None:
        self.hidden[:] = 0

    def step(self, x) -> tuple[np.ndarray, float | int]:
        b = self.blob
        z = np.clip((np.asarray(x, dtype=F32) - b.mean) / b.std, -b.clip, b.clip).astype(F32)
        if b.gru is not None:
            self.hidden[:] = gru_cell(z, self.hidden, *b.gru)
            features = np.concatenate([z, self.hidden])
        else:
            features = z
        for layer in b.layers:
            features = ACTIVATE[layer.activation]((layer.weight @ features + layer.bias).astype(F32)).astype(F32)
        action = int(np.argmax(features)) if b.output == "argmax" else float(features[0])
        return features, action


def gru_cell(x: np.ndarray, h: np.ndarray, w_ih: np.ndarray, w_hh: np.ndarray, b_ih: np.ndarray,
             b_hh: np.ndarray) -> np.ndarray:
    """PyTorch's GRU cell, gates in its order (reset, update, new)."""
    n = h.size
    gi = (w_ih @ x + b_ih).astype(F32)
    gh = (w_hh @ h + b_hh).astype(F32)
    r = _sigmoid(gi[:n] + gh[:n])
    u = _sigmoid(gi[n:2 * n] + gh[n:2 * n])
    candidate = np.tanh(gi[2 * n:] + r * gh[2 * n:]).astype(F32)
    return ((F32(1) - u) * candidate + u * h).astype(F32)


class StateFeedbackRuntime:
    """u = -K (x - x_ref), clipped to the output's limit."""

    def __init__(self, blob: StateFeedbackBlob) -> None:
        self.blob = blob

    def reset(self) -> None:
        pass

    def step(self, x) -> tuple[np.ndarray, float]:
        b = self.blob
        u = -float(np.dot(b.gain, np.asarray(x, dtype=F32) - b.reference))
        u = float(np.clip(np.float32(u), -b.output_limit, b.output_limit))
        return np.array([u], dtype=F32), u


def runtime_for(blob: NetworkBlob | StateFeedbackBlob):
    return NetworkRuntime(blob) if isinstance(blob, NetworkBlob) else StateFeedbackRuntime(blob)


class DevicePolicy:
    """A policy blob (`pendkit.device.policy_blob`) as the device runs it: every control step it makes the
    network's inputs from its newest reading, as the host's env would from the same reading arriving at
    once, and returns the action (None between steps: the last action goes on, as a host's would)."""

    continuous = False  # an action index (layout 1); `pendkit.device.observed_policy` gives a target

    def __init__(self, blob, params) -> None:
        self.blob, self.params = blob, params
        self.network = NetworkRuntime(blob.network)
        self.features = resolve_features("paper")
        self.ticks_per_step = max(1, round(blob.period_s / blob.acting_period_s))
        self.reset()

    def reset(self, *_) -> None:
        self.network.reset()
        self.last_action, self.tick_count = 0, self.ticks_per_step - 1  # the first tick decides

    def inputs(self, observation, now_ms: float) -> np.ndarray:
        state = observation_to_state(observation, self.params, (now_ms - observation.millis) / 1000.0,
                                     self.blob.period_s)
        values = [min(max(f.read(state), f.low), f.high) for f in self.features]
        one_hot = [0.0] * self.blob.actions
        one_hot[self.last_action] = 1.0
        return np.array(values + one_hot, dtype=F32)

    def tick(self, observation, now_ms: float) -> int | None:
        self.tick_count += 1
        if self.tick_count < self.ticks_per_step or observation is None:
            return None
        self.tick_count = 0
        _, action = self.network.step(self.inputs(observation, now_ms))
        self.last_action = int(action)
        return self.last_action
