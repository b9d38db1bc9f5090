"""Length-prefixed messages over a Unix socket: how the grader calls a student's functions once their
notebook has run. One socket round trip per batch of calls costs well under a millisecond, where a kernel
execute request costs about fifteen; the messages are the same data-only text as before (`wire`)."""

from __future__ import annotations

import socket
import struct

HEADER = struct.Struct(">Q")
MAX_MESSAGE_BYTES = 256 << 20  # well above the largest answer `wire` writes (arrays are capped)


class ChannelError(OSError):
    """The other side sent something that is not a message of this channel, or hung up mid-message."""


def send(sock: socket.socket, text: str) -> None:
    data = text.encode()
    sock.sendall(HEADER.pack(len(data)) + data)


def receive(sock: socket.socket) -> str | None:
    """The next message ("" is the end-of-calls message); None when the other side has closed."""
    header = _exactly(sock, HEADER.size)
    if header is None:
        return None
    (size,) = HEADER.unpack(header)
    if size > MAX_MESSAGE_BYTES:
        raise ChannelError(f"a message of {size} bytes, more than {MAX_MESSAGE_BYTES}")
    data = _exactly(sock, size) if size else b""
    if data is None:
        raise ChannelError("the connection closed in the middle of a message")
    return data.decode(errors="replace")


def _exactly(sock: socket.socket, size: int) -> bytes | None:
    chunks, missing = [], size
    while missing:
        chunk = sock.recv(min(missing, 1 << 20))
        if not chunk:
            return None
        chunks.append(chunk)
        missing -= len(chunk)
    return b"".join(chunks)
