"""A learned policy the device runs itself (blob kind 4): a network, and which inputs the device makes for
it from its own readings.

    input layout u16 | actions u16 | padding u32 | control step s f32 | acting tick s f32 |
    (layout 2: the observers, `pendkit.device.observer_blob`) | network payload

Layout 1 is the kit's "paper" observation (pendulum angle from upright, arm angle, pendulum rate and
acceleration, arm rate, time since the action, the reading's age) followed by the last action one-hot:
what `pendkit.agents.inputs.StepInputs` gives an R-DQN agent on the realistic twin. Layout 2 is a continuous
policy (one output, the servo's target through a first-order filter) reading the paper's features of its
observers' estimate, then of the reading, then its last actions (`features="estimated+measured"`, R-TD3 or
TD3); `actions` is then 1.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from pendkit.device.blob_parts import BlobError, NetworkBlob, network_payload, parse_network
from pendkit.device.observer_blob import ObserverSection, pack_observers, parse_observers
from pendkit.device.observer_runtime import MAX_SUBSTEPS, SUBSTEP_S

HEADER = struct.Struct("<HHIff")
LAYOUTS = {1: "paper features + the last action one-hot",
           2: "observers' estimate and the reading, paper features each, + the last actions; a continuous target"}
PAPER_INPUTS = 7
MAX_TICKS_PER_STEP = 1000


@dataclass
class PolicyBlob:
    network: NetworkBlob
    period_s: float
    acting_period_s: float
    actions: int = 5
    layout: int = 1
    observers: ObserverSection | None = None  # layout 2
    kind: str = field(default="policy", init=False)

    @property
    def multiply_accumulates(self) -> int:
        return self.network.multiply_accumulates


def pack_payload(blob: PolicyBlob) -> bytes:
    observers = pack_observers(blob.observers) if blob.layout == 2 else b""
    return HEADER.pack(blob.layout, blob.actions, 0, blob.period_s, blob.acting_period_s) + observers + \
        network_payload(blob.network)


def parse_payload(reader) -> PolicyBlob:
    layout, actions, _, period_s, acting_s = reader.take(HEADER.format)
    if layout not in LAYOUTS or not (2 <= actions <= 16 if layout == 1 else actions == 1):
        raise BlobError(f"input layout {layout} with {actions} actions")
    if not (0 < acting_s <= period_s < 10 and period_s / acting_s <= MAX_TICKS_PER_STEP):
        raise BlobError(f"a control step of {period_s} s on acting ticks of {acting_s} s")
    if layout == 2 and not period_s / SUBSTEP_S < MAX_SUBSTEPS + 0.5:
        raise BlobError(f"a control step of {period_s} s: an observed policy's is at most "
                        f"{MAX_SUBSTEPS * SUBSTEP_S:g} s")
    observers = parse_observers(reader) if layout == 2 else None
    network = parse_network(reader)
    inputs, output = (PAPER_INPUTS + actions, "argmax") if layout == 1 else \
        (2 * PAPER_INPUTS + observers.actions_seen, "continuous")
    if network.input_dim != inputs or network.output != output or network.layers[-1].weight.shape[0] != actions:
        raise BlobError(f"a network of {network.input_dim} inputs and {network.layers[-1].weight.shape[0]} outputs for "
                        f"layout {layout} with {actions} actions")
    return PolicyBlob(network, float(period_s), float(acting_s), actions, layout, observers)
