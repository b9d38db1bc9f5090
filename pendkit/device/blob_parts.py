"""What every controller blob is made of: its error, the network and state-feedback payloads' types, and
their packing and checked parsing (`pendkit.device.controller_blob` frames them; the policy blob wraps a
network payload)."""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

import numpy as np

from pendkit.errors import PendkitError

ACTIVATIONS = {"none": 0, "relu": 1, "tanh": 2, "sigmoid": 3}
OUTPUTS = {"argmax": 0, "continuous": 1}
MAX_WIDTH = 256


class BlobError(PendkitError, ValueError):
    """Bytes that are not a whole, intact controller of this format."""


@dataclass
class DenseLayer:
    weight: np.ndarray  # (out, in)
    bias: np.ndarray  # (out,)
    activation: str = "none"


@dataclass
class NetworkBlob:
    """[normalised input, GRU state] -> dense layers -> argmax or the raw output."""

    mean: np.ndarray
    std: np.ndarray
    clip: float
    layers: list[DenseLayer]
    gru: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None  # w_ih, w_hh, b_ih, b_hh
    output: str = "argmax"
    kind: str = field(default="network", init=False)

    @property
    def input_dim(self) -> int:
        return int(self.mean.size)

    @property
    def gru_size(self) -> int:
        return 0 if self.gru is None else int(self.gru[1].shape[1])

    @property
    def multiply_accumulates(self) -> int:
        """Per step: the GRU's gates and every dense layer (as the firmware's Controller counts them)."""
        return 3 * self.gru_size * (self.input_dim + self.gru_size) + sum(layer.weight.size for layer in self.layers)


@dataclass
class StateFeedbackBlob:
    gain: np.ndarray  # (state,)
    reference: np.ndarray  # (state,)
    output_limit: float
    kind: str = field(default="state-feedback", init=False)


def f32(values) -> bytes:
    return np.ascontiguousarray(values, dtype="<f4").tobytes()


def network_payload(blob: NetworkBlob) -> bytes:
    parts = [struct.pack("<HHHBB", blob.input_dim, blob.gru_size, len(blob.layers), OUTPUTS[blob.output], 0),
             f32(blob.mean), f32(blob.std), f32([blob.clip])]
    if blob.gru is not None:
        parts += [f32(w) for w in blob.gru]
    for layer in blob.layers:
        rows, cols = layer.weight.shape
        parts += [struct.pack("<HHBB", rows, cols, ACTIVATIONS[layer.activation], 0), f32(layer.weight),
                  f32(layer.bias)]
    return b"".join(parts)


class Reader:
    def __init__(self, data: bytes) -> None:
        self.data, self.at = data, 0

    def take(self, fmt: str) -> tuple:
        size = struct.calcsize(fmt)
        if self.at + size > len(self.data):
            raise BlobError("the payload ends before its shapes say it should")
        values = struct.unpack_from(fmt, self.data, self.at)
        self.at += size
        return values

    def floats(self, *shape: int) -> np.ndarray:
        count = int(np.prod(shape))
        if self.at + 4 * count > len(self.data):
            raise BlobError("the payload ends before its shapes say it should")
        values = np.frombuffer(self.data, dtype="<f4", count=count, offset=self.at).astype(np.float32)
        self.at += 4 * count
        if not np.all(np.isfinite(values)):
            raise BlobError("a weight is not a finite number")
        return values.reshape(shape)


def parse_network(reader: Reader) -> NetworkBlob:
    inputs, gru_size, layers, output, _ = reader.take("<HHHBB")
    if not (0 < inputs <= MAX_WIDTH and gru_size <= MAX_WIDTH and 0 < layers <= 8 and output in OUTPUTS.values()):
        raise BlobError(f"a network of {inputs} inputs, GRU {gru_size}, {layers} layers, output {output}")
    mean, std, (clip,) = reader.floats(inputs), reader.floats(inputs), reader.floats(1)
    if np.any(std <= 0) or clip <= 0:
        raise BlobError("the input normalisation needs positive scales")
    gru = None
    if gru_size:
        gru = (reader.floats(3 * gru_size, inputs), reader.floats(3 * gru_size, gru_size),
               reader.floats(3 * gru_size), reader.floats(3 * gru_size))
    width, dense = inputs + gru_size, []
    for _ in range(layers):
        rows, cols, activation, _ = reader.take("<HHBB")
        if cols != width or not 0 < rows <= MAX_WIDTH or activation not in ACTIVATIONS.values():
            raise BlobError(f"a {rows}x{cols} layer after a width of {width}")
        name = next(n for n, code in ACTIVATIONS.items() if code == activation)
        dense.append(DenseLayer(reader.floats(rows, cols), reader.floats(rows), name))
        width = rows
    return NetworkBlob(mean, std, float(clip), dense, gru, next(n for n, c in OUTPUTS.items() if c == output))


def parse_state_feedback(reader: Reader) -> StateFeedbackBlob:
    size, _ = reader.take("<HH")
    if not 0 < size <= 16:
        raise BlobError(f"a state of {size} values")
    gain, reference, (limit,) = reader.floats(size), reader.floats(size), reader.floats(1)
    if limit <= 0:
        raise BlobError("the output limit must be positive")
    return StateFeedbackBlob(gain, reference, float(limit))
