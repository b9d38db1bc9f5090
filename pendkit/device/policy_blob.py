"""A learned policy the device runs itself (blob kind 4): a network, and which inputs the device makes for
it from its own readings.

    input layout u16 | actions u16 | padding u32 | control step s f32 | acting tick s f32 | network payload

Layout 1 is the kit's "paper" observation (pendulum angle from upright, arm angle, pendulum rate and
acceleration, arm rate, time since the action, the reading's age) followed by the last action one-hot:
what `pendkit.agents.inputs.StepInputs` gives an R-DQN agent on the realistic twin.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from pendkit.device.blob_parts import BlobError, NetworkBlob, network_payload, parse_network

HEADER = struct.Struct("<HHIff")
LAYOUTS = {1: "paper features + the last action one-hot"}
PAPER_INPUTS = 7


@dataclass
class PolicyBlob:
    network: NetworkBlob
    period_s: float
    acting_period_s: float
    actions: int = 5
    layout: int = 1
    kind: str = field(default="policy", init=False)

    @property
    def multiply_accumulates(self) -> int:
        return self.network.multiply_accumulates


def pack_payload(blob: PolicyBlob) -> bytes:
    return HEADER.pack(blob.layout, blob.actions, 0, blob.period_s, blob.acting_period_s) + \
        network_payload(blob.network)


def parse_payload(reader) -> PolicyBlob:
    layout, actions, _, period_s, acting_s = reader.take(HEADER.format)
    if layout not in LAYOUTS or not 2 <= actions <= 16:
        raise BlobError(f"input layout {layout} with {actions} actions")
    if not (0 < acting_s <= period_s < 10):
        raise BlobError(f"a control step of {period_s} s on acting ticks of {acting_s} s")
    network = parse_network(reader)
    if network.input_dim != PAPER_INPUTS + actions or network.output != "argmax" or \
            network.layers[-1].weight.shape[0] != actions:
        raise BlobError(f"a network of {network.input_dim} inputs and {network.layers[-1].weight.shape[0]} outputs for "
                    f"layout {layout} with {actions} actions")
    return PolicyBlob(network, float(period_s), float(acting_s), actions, layout)
