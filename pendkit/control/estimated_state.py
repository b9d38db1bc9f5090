"""A state-estimating front end for any agent on any backend: the observer's estimate of the *present*
state in place of the raw readings.

On the rig (and the realistic twin) a reading is 0-20 ms old when it arrives, its rate is a mean over the
last 75 ms of quantised positions, and the arm angle it carries is the servo command, not the arm. The
`DelayedAngleObserver` predicts with the model through the commands sent since and corrects with the
encoder angle at the reading's own time. The env's `features="estimated"` uses this class, designed for
its backend's `BackendTiming`.
"""

from __future__ import annotations

from pendkit.backend_contract import BackendTiming, RigState, ServoCommand
from pendkit.control.model import FurutaModel
from pendkit.control.observer import DelayedAngleObserver
from pendkit.rig import RigParams


class EstimatedStateFeed:
    """`reset(state)` at an episode's start, `update(command, state)` after each step; both return the
    state to show the agent (estimated angles, rates and pendulum acceleration; the rest as measured)."""

    def __init__(self, params: RigParams, period_s: float, timing: BackendTiming) -> None:
        """`period_s`: the control step; `timing`: the backend's command and reading delays."""
        self.params = params
        self.model = FurutaModel.from_rig(params)
        self.observer = DelayedAngleObserver(self.model, period_s, timing.command_delay_s, timing.reading_delay_s)
        self._ramp_per_count_rad_s = params.servo_rad_per_count * 1000.0 / params.acting_period_ms

    def reset(self, state: RigState) -> RigState:
        self.observer.reset(state)
        return self._shown(state)

    def update(self, command: ServoCommand, state: RigState) -> RigState:
        """Predict over the step just taken with `command`, then fold in the newest reading `state`."""
        limit = self.params.servo_range_rad
        if command.mode == "continuous":
            self.observer.predict_ramp(command.target_unit * limit, 0.0, limit)
        else:
            ramp = command.increment_counts * self._ramp_per_count_rad_s
            self.observer.predict_ramp(None, ramp, limit)
        self.observer.correct(state)
        if command.mode == "discrete":  # the device's own count of where its target is, when it is known
            self.observer.target_in_force_rad = state.servo_target_rad
        return self._shown(state)

    def _shown(self, state: RigState) -> RigState:
        estimated = self.observer.as_state(state)
        x = self.observer.estimate
        _, pendulum_acceleration = self.model.accelerations(x, self.observer.target_in_force_rad)
        return estimated._replace(pendulum_acceleration_rad_s2=float(pendulum_acceleration))
