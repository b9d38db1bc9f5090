"""A continuous learned policy the device runs itself (policy layout 2): every control step its bank of
observers (`pendkit.device.observer_runtime`) takes the newest reading, and the network reads the paper's
features of the estimate, then of the reading itself, then its own last actions, as the host's env with
`features="estimated+measured"` shows them; its output, through the first-order filter it was trained
behind, is the servo's target."""

from __future__ import annotations

import math

import numpy as np

from pendkit.device.observation import observation_to_state
from pendkit.device.observer_runtime import DeviceObserverBank
from pendkit.device.policy_runtime import NetworkRuntime
from pendkit.features import resolve_features

F32 = np.float32
FLT_MAX = float(np.finfo(np.float32).max)


class ObservedDevicePolicy:
    """`reset()` at `k1`; `tick(observation, now_ms)` on every acting tick -> the target (a unit of the servo's
    range) on a deciding tick, None between them (the last target goes on)."""

    continuous = True

    def __init__(self, blob, params) -> None:
        self.blob, self.params = blob, params
        self.network = NetworkRuntime(blob.network)
        self.bank = DeviceObserverBank(blob.observers, blob.period_s)
        self.features = resolve_features("paper")
        self.ticks_per_step = max(1, round(blob.period_s / blob.acting_period_s))
        self.reset()

    def reset(self, *_) -> None:
        self.network.reset()
        self.tick_count = self.ticks_per_step - 1  # the first tick decides
        self.started = False
        self.recent = [0.0] * self.blob.observers.actions_seen  # the newest first, as the host's StepInputs
        self.target_unit = 0.0
        self.network_inputs = None  # what the last decision was made from
        self.action = 0.0  # the network's last output, before the filter

    def inputs(self, observation, now_ms: float) -> np.ndarray:
        state = observation_to_state(observation, self.params, (now_ms - observation.millis) / 1000.0,
                                     self.blob.period_s)
        if not self.started:
            shown = self.bank.reset(state)
            self.started = True
            self.target_unit = state.servo_target_rad / self.params.servo_range_rad
        else:
            shown = self.bank.update(self.target_unit, state)
        values = [min(max(f.read(s), f.low), f.high) for s in (shown, state) for f in self.features]
        return np.clip(np.array(values + self.recent), -FLT_MAX, FLT_MAX).astype(F32)  # as the C++ core narrows

    def follow(self, action: float, target_unit: float) -> None:
        """Take `action` and `target_unit` as the last decision's: a replay of recorded decisions (the shared
        vectors) keeps both sides on the recording, since a float's last bit, fed back through the observers
        and the GRU, grows over an episode."""
        self.recent = [action, *self.recent[1:]]
        self.target_unit = target_unit

    def tick(self, observation, now_ms: float) -> float | None:
        self.tick_count += 1
        if self.tick_count < self.ticks_per_step or observation is None:
            return None
        self.tick_count = 0
        self.network_inputs = self.inputs(observation, now_ms)
        _, action = self.network.step(self.network_inputs)
        if not math.isfinite(action):  # diverged observers: the servo holds its target, as in the C++ core
            return None
        action = min(max(float(action), -1.0), 1.0)
        self.recent = [action, *self.recent[:-1]]
        self.action = action
        c = self.blob.observers.filter_coefficient
        self.target_unit = c * self.target_unit + (1 - c) * action
        return self.target_unit
