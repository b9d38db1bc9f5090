"""Lab 10: a student's upload chunks read as the rig reads them, and the first thing wrong said in words a
student can act on (before the rig sees them: the rig itself only reports a blob that does not add up)."""

from __future__ import annotations

import struct

from pendkit.device.onboard import CHUNK_HEADER, CHUNK_MAGIC, MAX_CHUNK_BYTES


def chunk_problem(chunks, blob: bytes, start: int = 0) -> str | None:
    """None when `chunks` send `blob` from byte `start` to its end as the rig expects; else what is wrong."""
    expected = start
    for k, chunk in enumerate(chunks):
        if not isinstance(chunk, (bytes, bytearray)):
            return f"chunk {k} is a {type(chunk).__name__}, not bytes"
        if len(chunk) < CHUNK_HEADER.size or chunk[:4] != CHUNK_MAGIC:
            return f"chunk {k} does not start with {CHUNK_MAGIC!r} and its two numbers ({CHUNK_HEADER.size} bytes)"
        _, offset, total = CHUNK_HEADER.unpack_from(chunk)
        if (offset, total) != (expected, len(blob)):
            _, big_offset, big_total = struct.unpack_from(">4sII", chunk)
            if (big_offset, big_total) == (expected, len(blob)):
                return (f"chunk {k}'s offset and size are big-endian; the rig reads little-endian "
                        f"(struct.pack(\"<II\", offset, size))")
            return (f"chunk {k}'s header says offset {offset} and size {total}; the rig expects offset {expected} "
                    f"(where the previous chunk ended) and size {len(blob)} (the whole blob)")
        payload = bytes(chunk[CHUNK_HEADER.size:])
        if not 0 < len(payload) <= MAX_CHUNK_BYTES:
            return f"chunk {k} carries {len(payload)} bytes of the blob; a chunk carries 1 to {MAX_CHUNK_BYTES}"
        if payload != blob[offset:offset + len(payload)]:
            return f"chunk {k}'s bytes are not the blob's bytes {offset}-{offset + len(payload) - 1}"
        expected = offset + len(payload)
    if expected != len(blob):
        return f"the chunks stop at byte {expected}; the blob has {len(blob)}: the last chunk must reach its end"
    return None
