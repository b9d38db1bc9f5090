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

from pendkit.device import policy_blob, swingup_blob
from pendkit.device.blob_parts import (
    BlobError,
    DenseLayer,
    NetworkBlob,
    Reader,
    StateFeedbackBlob,
    f32,
    network_payload,
    parse_network,
    parse_state_feedback,
)

MAGIC = b"PKCB"
VERSION = 1
HEADER = struct.Struct("<4sHHI")
CRC = struct.Struct("<I")
MAX_BLOB_BYTES = 64 * 1024  # a fifth of the ESP32-S2's 320 KB of SRAM; the shipped R-DQN is 47 KB
KINDS = {"network": 1, "state-feedback": 2, "swing-up": 3, "policy": 4}
__all__ = ["MAX_BLOB_BYTES", "BlobError", "DenseLayer", "NetworkBlob", "StateFeedbackBlob", "pack", "parse"]


def _non_finite(value, where: str = "") -> str | None:
    """The first number in a blob's fields that is NaN or infinite (a diverged training), by where it is."""
    import dataclasses

    import numpy as np

    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        for field in dataclasses.fields(value):
            found = _non_finite(getattr(value, field.name), f"{where}.{field.name}".lstrip("."))
            if found:
                return found
        return None
    if isinstance(value, (list, tuple, dict)):
        items = value.items() if isinstance(value, dict) else enumerate(value)
        for k, item in items:
            found = _non_finite(item, f"{where}[{k!r}]")
            if found:
                return found
        return None
    if isinstance(value, (float, np.ndarray, np.floating)) and not np.all(np.isfinite(np.asarray(value, float))):
        return where or "a value"
    return None


def pack(blob) -> bytes:
    """The blob's bytes (a NetworkBlob, StateFeedbackBlob or SwingUpBlob); BlobError for one holding NaN or
    infinity (a device refuses it: better said here, before an upload)."""
    bad = _non_finite(blob)
    if bad:
        raise BlobError(f"the controller's {bad} holds NaN or infinity (diverged training?): nothing was written")
    if blob.kind == "swing-up":
        parts = [swingup_blob.pack_payload(blob)]
    elif blob.kind == "policy":
        parts = [policy_blob.pack_payload(blob)]
    elif isinstance(blob, NetworkBlob):
        parts = [network_payload(blob)]
    else:
        parts = [struct.pack("<HH", blob.gain.size, 0), f32(blob.gain), f32(blob.reference),
                 f32([blob.output_limit])]
    payload = b"".join(parts)
    head = HEADER.pack(MAGIC, VERSION, KINDS[blob.kind], len(payload)) + payload
    data = head + CRC.pack(zlib.crc32(head))
    if len(data) > MAX_BLOB_BYTES:
        raise BlobError(f"the controller is {len(data)} bytes, more than a rig takes ({MAX_BLOB_BYTES})")
    return data


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
    reader = Reader(data[HEADER.size:-CRC.size])
    if kind == KINDS["network"]:
        blob = parse_network(reader)
    elif kind == KINDS["state-feedback"]:
        blob = parse_state_feedback(reader)
    elif kind == KINDS["swing-up"]:
        blob = swingup_blob.parse_payload(reader)
    elif kind == KINDS["policy"]:
        blob = policy_blob.parse_payload(reader)
    else:
        raise BlobError(f"unknown controller kind {kind}")
    if reader.at != len(reader.data):
        raise BlobError("bytes left over after the last layer")
    return blob
