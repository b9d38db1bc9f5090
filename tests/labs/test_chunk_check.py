"""Lab 10's reading of a student's chunks: right ones pass, and each usual mistake is named."""

import struct

from pendkit.device.onboard import blob_chunks
from pendkit.labs.chunk_check import chunk_problem

BLOB = bytes(range(256)) * 5  # 1280 bytes: two chunks


def test_the_kits_chunks_pass_from_the_start_and_from_a_resume():
    assert chunk_problem(blob_chunks(BLOB), BLOB) is None
    assert chunk_problem(blob_chunks(BLOB, 1024), BLOB, 1024) is None


def test_each_mistake_is_named():
    big = [b"PKUP" + struct.pack(">II", o, len(BLOB)) + BLOB[o:o + 1024] for o in range(0, len(BLOB), 1024)]
    assert "big-endian" in chunk_problem(big, BLOB)
    assert "must reach its end" in chunk_problem(blob_chunks(BLOB)[:1], BLOB)
    assert "does not start with" in chunk_problem([BLOB[:1024]], BLOB)
    resumed_from_zero = blob_chunks(BLOB)
    assert "expects offset 1024" in chunk_problem(resumed_from_zero, BLOB, 1024)
    chunk_sized = [struct.pack("<4sII", b"PKUP", o, len(BLOB)) + BLOB[o:o + 2048] for o in range(0, len(BLOB), 2048)]
    assert "1 to 1024" in chunk_problem(chunk_sized, BLOB)
    assert "not bytes" in chunk_problem(["PKUP"], BLOB)
