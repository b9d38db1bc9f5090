"""The observers a learned policy reads on the device (policy layout 2): one model and gain per candidate rig,
and the timing they are designed for.

    candidates u16 | actions seen u16 | actuation delay s f32 | reading latency s f32 | forgetting f32 |
    filter coefficient f32 | per candidate: its model (MODEL_FIELDS, f32 each) then its gain (4 f32)

A candidate's model is the lumped rigid-body model of `pendkit.control.model.FurutaModel`, in its field order;
its gain is the steady-state Kalman gain the host computed for it (the device solves no Riccati equation).
The forgetting factor weights the newest squared innovation in each candidate's running miss
(`pendkit.control.observer_bank`); the filter coefficient is the first-order filter on the policy's target.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from pendkit.device.blob_parts import BlobError, f32
from pendkit.device.physical_ranges import model_problem

MODEL_FIELDS = ("arm_inertia_kg_m2", "pendulum_inertia_kg_m2", "pendulum_long_axis_inertia_kg_m2", "coupling_kg_m2",
                "gravity_torque_n_m", "pendulum_damping_n_m_s_per_rad", "arm_damping_n_m_s_per_rad",
                "servo_kp_n_m_per_rad", "servo_kv_n_m_s_per_rad", "servo_stall_torque_n_m", "servo_range_rad")
HEADER = struct.Struct("<HHffff")
MAX_CANDIDATES = 16  # each costs about 0.7 ms of a 60 ms step on the S2's soft floats (docs/on-device.md)


@dataclass
class ObserverSection:
    models: np.ndarray  # (candidates, len(MODEL_FIELDS))
    gains: np.ndarray  # (candidates, 4)
    actuation_delay_s: float
    reading_latency_s: float
    forgetting: float
    filter_coefficient: float
    actions_seen: int = 1

    @property
    def candidates(self) -> int:
        return int(self.models.shape[0])


def pack_observers(section: ObserverSection) -> bytes:
    return HEADER.pack(section.candidates, section.actions_seen, section.actuation_delay_s, section.reading_latency_s,
                       section.forgetting, section.filter_coefficient) + \
        b"".join(f32(model) + f32(gain) for model, gain in zip(section.models, section.gains))


def parse_observers(reader) -> ObserverSection:
    count, seen, actuation_s, reading_s, forgetting, coefficient = reader.take(HEADER.format)
    if not 1 <= count <= MAX_CANDIDATES or not 1 <= seen <= 8:
        raise BlobError(f"{count} observers and {seen} actions seen (1-{MAX_CANDIDATES} and 1-8)")
    if not (0 <= actuation_s < 1 and 0 <= reading_s < 1 and 0 < forgetting <= 1 and 0 <= coefficient < 1):
        raise BlobError(f"observer timing {actuation_s} s / {reading_s} s, forgetting {forgetting}, "
                        f"filter {coefficient}: out of range")
    models, gains = [], []
    for _ in range(count):
        models.append(reader.floats(len(MODEL_FIELDS)))
        gains.append(reader.floats(4))
    models = np.stack(models)
    if np.any(models[:, [0, 1, 2, 4, 9, 10]] <= 0):
        raise BlobError("an observer's model needs positive inertias, gravity torque, stall torque and range")
    for k, model in enumerate(models):
        problem = model_problem(model)  # each term in its physical range (the firmware's parser agrees)
        if problem is not None:
            raise BlobError(f"observer {k + 1} of {count}: {problem}")
    return ObserverSection(models, np.stack(gains), float(actuation_s), float(reading_s), float(forgetting),
                           float(coefficient), int(seen))
