"""A bank of observers for a rig the laptop does not know: one observer per candidate rig, all fed the same
commands and readings, and the estimate shown is that of the one whose model has lately predicted the
readings best (a multiple-model estimator).

An observer designed for the wrong rig predicts the pendulum wrongly between readings, and a policy
trained with observers that knew each rig then acts on a biased state. Every observer in the bank makes a
prediction of each new reading; the squared miss (the innovation), averaged over the last `memory_s`
seconds, ranks them. No rig time is spent: the bank reads the rig as it swings up.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pendkit.backend_contract import BackendTiming, RigState, ServoCommand
from pendkit.control.estimated_state import EstimatedStateFeed
from pendkit.errors import ConfigError
from pendkit.rig import RigParams

DEFAULT_MEMORY_S = 1.0


class ObserverBank:
    """`EstimatedStateFeed`'s interface over several candidate rigs: `reset(state)`, `update(command,
    state)`; `chosen` is the index of the rig whose estimate was shown last (the first until the readings
    tell them apart)."""

    def __init__(self, candidates: Sequence[RigParams], period_s: float, timing: BackendTiming,
                 memory_s: float = DEFAULT_MEMORY_S) -> None:
        if not candidates:
            raise ConfigError("an observer bank needs at least one candidate rig")
        if not memory_s > 0:
            raise ConfigError(f"memory_s must be > 0, got {memory_s}")
        self.candidates = tuple(candidates)
        self.feeds = [EstimatedStateFeed(params, period_s, timing) for params in self.candidates]
        self.forgetting = min(1.0, period_s / memory_s)
        self.misses = np.zeros(len(self.feeds))
        self.chosen = 0

    @property
    def params(self) -> RigParams:
        """The candidate rig whose estimate is shown."""
        return self.candidates[self.chosen]

    def reset(self, state: RigState) -> RigState:
        shown = [feed.reset(state) for feed in self.feeds]
        self.misses[:] = 0.0
        self.chosen = 0
        return shown[0]

    def update(self, command: ServoCommand, state: RigState) -> RigState:
        shown = [feed.update(command, state) for feed in self.feeds]
        squared = np.array([feed.observer.last_innovation_rad ** 2 for feed in self.feeds])
        self.misses += self.forgetting * (squared - self.misses)
        self.chosen = int(np.argmin(self.misses))
        return shown[self.chosen]


def observer_feed(design: RigParams | tuple[RigParams, ...], period_s: float, timing: BackendTiming):
    """An observer designed for one rig, or a bank of them for a tuple of candidate rigs."""
    if isinstance(design, tuple):
        return ObserverBank(design, period_s, timing)
    return EstimatedStateFeed(design, period_s, timing)
