"""The swing-up controller's blob payload (kind 3): energy pumping, an optional planned swing-up from rest
with its time-varying gains, and the LQR hand-over, with the device's own observer.

    plan steps u16 | settle steps u16 | warm-up steps u16 | padding u16 | SCALARS (float32 each, in order)
    | balance gain (5) | settle gain (5)
    | plan: targets (N), states (N x 5), gains (N x 5)

The gains act on x = [arm, pendulum (from the bottom on the plan, from upright otherwise), arm rate,
pendulum rate, target in force], as the host's controllers do (`pendkit.control`).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numpy as np

from pendkit.device.blob_parts import BlobError, f32
from pendkit.device.physical_ranges import swing_up_problem

HEADER = struct.Struct("<HHHH")
SCALARS = ("period_s", "acting_period_s", "observer_angle_gain", "observer_rate_gain", "natural_frequency_rad_s",
           "energy_gain", "swing_rate_rad_s", "centring_per_s", "arm_limit_rad", "target_energy",
           "catch_angle_rad", "catch_velocity_rad_s", "fall_angle_rad", "filter_coefficient", "servo_range_rad",
           "rest_angle_rad", "rest_velocity_rad_s", "drift_rad",
           # the model the estimate predicts with, per unit of inertia (pendkit.control.model.FurutaModel)
           "servo_kp_per_inertia", "servo_kv_per_inertia", "arm_damping_per_inertia", "stall_per_inertia",
           "coupling_per_inertia", "pendulum_damping_per_inertia")
MAX_PLAN_STEPS = 200
ESTIMATE_MACS_PER_TICK = 20  # two arm substeps (7 each) and the pendulum's prediction and correction (6)


@dataclass
class SwingUpBlob:
    """Everything the device's swing-up needs; `scalars` by the names in SCALARS."""

    scalars: dict[str, float]
    balance_gain: np.ndarray  # (5,)
    settle_gain: np.ndarray  # (5,)
    plan_targets: np.ndarray = field(default_factory=lambda: np.zeros(0, np.float32))  # (N,)
    plan_states: np.ndarray = field(default_factory=lambda: np.zeros((0, 5), np.float32))  # (N, 5)
    plan_gains: np.ndarray = field(default_factory=lambda: np.zeros((0, 5), np.float32))  # (N, 5)
    settle_steps: int = 0
    warmup_steps: int = 0
    kind: str = field(default="swing-up", init=False)

    def __getattr__(self, name: str) -> float:
        scalars = self.__dict__.get("scalars", {})
        if name in scalars:
            return scalars[name]
        raise AttributeError(name)

    @property
    def plan_steps(self) -> int:
        return int(self.plan_targets.size)

    @property
    def multiply_accumulates(self) -> int:
        """Per control step: the gain (5), the plan's correction (5); per acting tick the estimate's about 20."""
        ticks = round(self.period_s / self.acting_period_s)
        return 10 + ESTIMATE_MACS_PER_TICK * ticks


def pack_payload(blob: SwingUpBlob) -> bytes:
    scalars = [blob.scalars[name] for name in SCALARS]
    header = HEADER.pack(blob.plan_steps, blob.settle_steps, blob.warmup_steps, 0)
    arrays = (scalars, blob.balance_gain, blob.settle_gain, blob.plan_targets, blob.plan_states, blob.plan_gains)
    return header + b"".join(f32(values) for values in arrays)


def parse_payload(reader) -> SwingUpBlob:
    steps, settle, warmup, _ = reader.take(HEADER.format)
    if steps > MAX_PLAN_STEPS or settle > 1000 or warmup > 100:
        raise BlobError(f"a plan of {steps} steps, {settle} settling and {warmup} warm-up steps")
    values = dict(zip(SCALARS, (float(v) for v in reader.floats(len(SCALARS)))))
    for name in ("period_s", "acting_period_s", "natural_frequency_rad_s", "servo_range_rad", "arm_limit_rad",
                 "servo_kp_per_inertia", "stall_per_inertia"):
        if values[name] <= 0:
            raise BlobError(f"{name} must be positive")
    if values["period_s"] < values["acting_period_s"] or not 0 <= values["filter_coefficient"] < 1:
        raise BlobError("the control step must be at least one acting tick, the filter coefficient in [0, 1)")
    problem = swing_up_problem(values)  # the model's terms in their physical ranges (the firmware's parser agrees)
    if problem is not None:
        raise BlobError(f"the swing-up's {problem}")
    blob = SwingUpBlob(values, reader.floats(5), reader.floats(5),
                       reader.floats(steps), reader.floats(steps, 5), reader.floats(steps, 5), settle, warmup)
    return blob
