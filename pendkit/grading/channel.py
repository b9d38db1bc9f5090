"""Length-prefixed messages over a Unix socket: how the grader calls a student's functions once their
notebook has run. One socket round trip per batch of calls costs well under a millisecond, where a kernel
execute request costs about fifteen; the messages are the same data-only text as before (`wire`)."""

from __future__ import annotations

import socket
import struct
import time

HEADER = struct.Struct(">Q")
MAX_MESSAGE_BYTES = 256 << 20  # the grader's requests: well above the largest `wire` writes (arrays are capped)


class ChannelError(OSError):
    """The other side sent something that is not a message of this channel, or hung up mid-message."""


def send(sock: socket.socket, text: str) -> None:
    data = text.encode()
    sock.sendall(HEADER.pack(len(data)) + data)


class TooLarge(ChannelError):
    """A message longer than the reader takes: refused from its header, before any of it is read."""

    def __init__(self, size: int, limit: int) -> None:
        super().__init__(f"a message of {size} bytes, more than the {limit} taken")
        self.size, self.limit = size, limit


def receive(sock: socket.socket, deadline: float | None = None, max_bytes: int = MAX_MESSAGE_BYTES) -> str | None:
    """The next message ("" is the end-of-calls message); None when the other side has closed.
    `deadline` (time.monotonic()) bounds the whole message, however slowly it trickles in (TimeoutError);
    a message over `max_bytes` raises TooLarge unread."""
    header = _exactly(sock, HEADER.size, deadline)
    if header is None:
        return None
    (size,) = HEADER.unpack(header)
    if size > max_bytes:
        raise TooLarge(size, max_bytes)
    data = _exactly(sock, size, deadline) if size else b""
    if data is None:
        raise ChannelError("the connection closed in the middle of a message")
    return data.decode(errors="replace")


def _exactly(sock: socket.socket, size: int, deadline: float | None) -> bytes | None:
    chunks, missing = [], size
    while missing:
        if deadline is not None:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise TimeoutError("the message did not arrive whole in time")
            sock.settimeout(remaining)
        chunk = sock.recv(min(missing, 1 << 20))
        if not chunk:
            return None
        chunks.append(chunk)
        missing -= len(chunk)
    return b"".join(chunks)
