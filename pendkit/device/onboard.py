"""A controller the device runs itself: its upload in chunks, the active one, and whether it runs.

A chunk is binary, on the rig's controller topic (`pendulum-r/ctl/<rig>`, v2 only):

    magic "PKUP" | offset u32 | blob size u32 | up to 1024 bytes of the blob

An upload starts with the chunk at offset 0; the next chunk must start where the device has got to
(`received` in the status), others are ignored and counted, so a host resumes after a lost one. When the
last byte arrives the blob is checked whole (`controller_blob.parse`): accepted, it replaces the active
controller (which stops: the servo holds until `k1`); refused, it is counted with its reason and the
active controller stays. `k1` starts the active controller, `k0` stops it, and so does any action or target
command (the host takes over). The safety stops act after the controller, as on every other target.
"""

from __future__ import annotations

import math
import struct
import zlib

from pendkit.device.controller_blob import MAX_BLOB_BYTES, BlobError, parse
from pendkit.device.observed_policy import ObservedDevicePolicy
from pendkit.device.policy_runtime import DevicePolicy
from pendkit.device.swingup_runtime import SwingUpRuntime
from pendkit.rig import RigParams

DIVERGED = (ArithmeticError, ValueError)  # math.sin(inf) and friends: NaN in the C++ core
CHUNK_MAGIC = b"PKUP"
CHUNK_HEADER = struct.Struct("<4sII")
MAX_CHUNK_BYTES = 1024
RUNNABLE_KINDS = ("swing-up", "policy")


def blob_chunks(blob: bytes, start: int = 0, chunk_bytes: int = MAX_CHUNK_BYTES) -> list[bytes]:
    """The chunks that send `blob` from byte `start` on."""
    return [CHUNK_HEADER.pack(CHUNK_MAGIC, offset, len(blob)) + blob[offset:offset + chunk_bytes]
            for offset in range(start, len(blob), chunk_bytes)]


def is_chunk(payload: bytes | str) -> bool:
    return isinstance(payload, bytes) and payload[:4] == CHUNK_MAGIC


class OnboardController:
    """The device's side of uploads and of running an uploaded controller."""

    def __init__(self, params=None) -> None:
        """`params`: the rig's (a policy's inputs are made in its units; default the kit's rig)."""
        self.params = params
        self.buffer = bytearray()
        self.total = 0
        self.blob = None
        self.runtime = None
        self.active_bytes = self.active_crc = 0
        self.running = False
        self.blobs_accepted = self.blobs_refused = self.chunks_ignored = 0
        self.last_refusal = ""

    def _refuse(self, reason: str) -> None:
        self.blobs_refused += 1
        self.last_refusal = reason
        self.buffer, self.total = bytearray(), 0

    def chunk(self, payload: bytes) -> None:
        """Take one chunk (see the module docstring); never raises."""
        if len(payload) < CHUNK_HEADER.size or payload[:4] != CHUNK_MAGIC:
            self.chunks_ignored += 1
            return
        _, offset, total, = CHUNK_HEADER.unpack_from(payload)
        data = payload[CHUNK_HEADER.size:]
        if len(data) > MAX_CHUNK_BYTES or not data:
            self.chunks_ignored += 1
            return
        if offset == 0:
            if total > MAX_BLOB_BYTES:
                self._refuse(f"{total} bytes, more than a rig takes ({MAX_BLOB_BYTES})")
                return
            self.buffer, self.total = bytearray(), total
        elif total != self.total or offset != len(self.buffer) or not self.total:
            self.chunks_ignored += 1  # a chunk after a lost one, or of another upload: the host resumes
            return
        if offset + len(data) > self.total:
            self._refuse("a chunk runs past the blob's size")
            return
        self.buffer += data
        if len(self.buffer) == self.total:
            self._install(bytes(self.buffer))

    def _install(self, data: bytes) -> None:
        try:
            blob = parse(data)
        except BlobError as error:
            self._refuse(str(error))
            return
        if blob.kind not in RUNNABLE_KINDS:
            self._refuse(f"a {blob.kind} controller: this device runs {', '.join(RUNNABLE_KINDS)}")
            return
        if blob.kind == "policy":
            runtime = (ObservedDevicePolicy if blob.layout == 2 else DevicePolicy)(blob, self.params or RigParams())
        else:
            runtime = SwingUpRuntime(blob)
        self.blob, self.runtime = blob, runtime
        self.active_bytes, self.active_crc = len(data), zlib.crc32(data)
        self.running = False
        self.blobs_accepted += 1
        self.buffer, self.total = bytearray(), 0

    def start(self, pendulum_rad: float, target_rad: float) -> bool:
        """Run the active controller from this reading; False (and nothing runs) when there is none."""
        if self.runtime is None:
            return False
        self.runtime.reset(pendulum_rad, target_rad)
        self.running = True
        return True

    def stop(self) -> None:
        self.running = False

    def tick(self, pendulum_rad: float, target_in_force_rad: float) -> float:
        """A swing-up's acting tick: the target (rad) to hold; NaN where its arithmetic failed (Python raises
        where the C++ core's floats go NaN: the device then holds the servo, as the firmware does)."""
        try:
            return self.runtime.tick(pendulum_rad, target_in_force_rad)
        except DIVERGED:
            return math.nan

    def policy_tick(self, observation, now_ms: float):
        """A policy's acting tick: its decision, or None (none this tick, or its arithmetic failed: the servo
        holds its target, as in the C++ core)."""
        try:
            return self.runtime.tick(observation, now_ms)
        except DIVERGED:
            return None

    @property
    def runs_a_policy(self) -> bool:
        return self.blob is not None and self.blob.kind == "policy"

    def status(self) -> dict:
        return {"kind": None if self.blob is None else self.blob.kind, "bytes": self.active_bytes,
                "crc": self.active_crc, "running": self.running, "received": len(self.buffer), "total": self.total,
                "accepted": self.blobs_accepted, "refused": self.blobs_refused, "ignored_chunks": self.chunks_ignored,
                "last_refusal": self.last_refusal}
