"""One binary format for a controller a rig runs itself: a learned network or a state-feedback law.

    magic "PKCB" | version u16 | kind u16 | payload bytes u32 | payload | CRC32 of all before it, u32

little-endian throughout, every number float32. A network's payload: input size, GRU size (0: none),
layer count, output (0 argmax, 1 continuous), the input normalisation (mean, std, clip), the GRU's
weights in PyTorch's gate order (r, z, n), then per dense layer its shape, activation and weights. A
state-feedback payload: the state size, the gain K (u = -K (x - x_ref)) and x_ref, the output's limit.
A swing-up payload: `pendkit.device.swingup_blob`; a policy (a network with the inputs the device makes
for it): `pendkit.device.policy_blob`.
`parse` checks everything (size, magic, version, CRC, shapes against the payload) before it returns;
anything else is a `BlobError` and nothing is built from it. The firmware's parser reads the same bytes.
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass, field

import numpy as np

from pendkit.errors import PendkitError

MAGIC = b"PKCB"
VERSION = 1
HEADER = struct.Struct("<4sHHI")
CRC = struct.Struct("<I")
MAX_BLOB_BYTES = 64 * 1024  # a fifth of the ESP32-S2's 320 KB of SRAM; the shipped R-DQN is 47 KB
KINDS = {"network": 1, "state-feedback": 2, "swing-up": 3, "policy": 4}
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


def _f32(values) -> bytes:
    return np.ascontiguousarray(values, dtype="<f4").tobytes()


def pack(blob) -> bytes:
    """The blob's bytes (a NetworkBlob, StateFeedbackBlob or SwingUpBlob)."""
    if blob.kind == "swing-up":
        from pendkit.device.swingup_blob import pack_payload

        parts = [pack_payload(blob, _f32)]
    elif blob.kind == "policy":
        from pendkit.device.policy_blob import pack_payload

        parts = [pack_payload(blob, network_payload)]
    elif isinstance(blob, NetworkBlob):
        parts = [network_payload(blob)]
    else:
        parts = [struct.pack("<HH", blob.gain.size, 0), _f32(blob.gain), _f32(blob.reference),
                 _f32([blob.output_limit])]
    payload = b"".join(parts)
    head = HEADER.pack(MAGIC, VERSION, KINDS[blob.kind], len(payload)) + payload
    data = head + CRC.pack(zlib.crc32(head))
    if len(data) > MAX_BLOB_BYTES:
        raise BlobError(f"the controller is {len(data)} bytes, more than a rig takes ({MAX_BLOB_BYTES})")
    return data


def network_payload(blob: NetworkBlob) -> bytes:
    parts = [struct.pack("<HHHBB", blob.input_dim, blob.gru_size, len(blob.layers), OUTPUTS[blob.output], 0),
             _f32(blob.mean), _f32(blob.std), _f32([blob.clip])]
    if blob.gru is not None:
        parts += [_f32(w) for w in blob.gru]
    for layer in blob.layers:
        rows, cols = layer.weight.shape
        parts += [struct.pack("<HHBB", rows, cols, ACTIVATIONS[layer.activation], 0), _f32(layer.weight),
                  _f32(layer.bias)]
    return b"".join(parts)


class _Reader:
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


def parse(data: bytes):
    """The controller in `data`, checked whole (see the module docstring); BlobError otherwise."""
    if len(data) > MAX_BLOB_BYTES:
        raise BlobError(f"{len(data)} bytes, more than a rig takes ({MAX_BLOB_BYTES})")
    if len(data) < HEADER.size + CRC.size:
        raise BlobError(f"{len(data)} bytes: too short for a controller")
    magic, version, kind, size = HEADER.unpack_from(data)
    if magic != MAGIC:
        raise BlobError("not a pendkit controller (bad magic)")
    if version != VERSION:
        raise BlobError(f"format version {version}; this side reads {VERSION}")
    if HEADER.size + size + CRC.size != len(data):
        raise BlobError(f"the header says {size} bytes of payload, the blob has {len(data) - HEADER.size - CRC.size}")
    (crc,) = CRC.unpack_from(data, len(data) - CRC.size)
    if zlib.crc32(data[:-CRC.size]) != crc:
        raise BlobError("CRC mismatch: the blob was damaged or cut")
    reader = _Reader(data[HEADER.size:-CRC.size])
    if kind == KINDS["network"]:
        blob = _parse_network(reader)
    elif kind == KINDS["state-feedback"]:
        blob = _parse_state_feedback(reader)
    elif kind == KINDS["swing-up"]:
        from pendkit.device.swingup_blob import parse_payload

        blob = parse_payload(reader, BlobError)
    elif kind == KINDS["policy"]:
        from pendkit.device.policy_blob import parse_payload as parse_policy

        blob = parse_policy(reader, BlobError, _parse_network)
    else:
        raise BlobError(f"unknown controller kind {kind}")
    if reader.at != len(reader.data):
        raise BlobError("bytes left over after the last layer")
    return blob


def _parse_network(reader: _Reader) -> NetworkBlob:
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


def _parse_state_feedback(reader: _Reader) -> StateFeedbackBlob:
    size, _ = reader.take("<HH")
    if not 0 < size <= 16:
        raise BlobError(f"a state of {size} values")
    gain, reference, (limit,) = reader.floats(size), reader.floats(size), reader.floats(1)
    if limit <= 0:
        raise BlobError("the output limit must be positive")
    return StateFeedbackBlob(gain, reference, float(limit))
