"""Episode logs: every message with the host's time, one JSON object per line.

    {"t_s": 12.345678, "dir": "rx", "topic": "pendulum-r/obs/r01", "payload": "S1234,512,300,0.0,0.0,0.0"}

The rig backend and the realistic twin write the same format; system identification reads it.
"""

from __future__ import annotations

import json
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendkit.device.protocol import ProtocolError
from pendkit.safe_write import open_new
from pendkit.telemetry.parse import parse_observation


@dataclass(frozen=True)
class LogRecord:
    t_s: float
    direction: str  # "rx" (device to host) or "tx" (host to device)
    topic: str
    payload: str


class EpisodeLog:
    """Append-only writer; use as a context manager or call `close()`."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._file = open_new(self.path)  # never through a link planted there
        self._lock = threading.Lock()  # the link's network thread writes too

    def write(self, t_s: float, direction: str, topic: str, payload: str) -> None:
        line = json.dumps({"t_s": round(t_s, 6), "dir": direction, "topic": topic, "payload": payload}) + "\n"
        with self._lock:
            if not self._file.closed:  # a message racing the end of an episode is dropped, not fatal
                self._file.write(line)

    def flush(self) -> None:
        with self._lock:
            if not self._file.closed:
                self._file.flush()

    def close(self) -> None:
        with self._lock:
            self._file.close()

    def __enter__(self) -> EpisodeLog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def read_log(path: str | Path) -> list[LogRecord]:
    records = []
    for line in Path(path).read_text().splitlines():
        if line.strip():
            item = json.loads(line)
            records.append(LogRecord(item["t_s"], item["dir"], item["topic"], item["payload"]))
    return records


@dataclass(frozen=True)
class Readings:
    """Observations of a log as arrays, on the device's clock."""

    millis: np.ndarray
    position_counts: np.ndarray
    servo_counts: np.ndarray
    omega_rev_s: np.ndarray
    host_time_s: np.ndarray
    malformed: int


def readings_from_log(path: str | Path) -> Readings:
    """Every well-formed observation in a log (malformed ones are counted, not fatal)."""
    return readings_of(read_log(path))


def readings_of(records: list[LogRecord]) -> Readings:
    """Every well-formed observation among `records`, in their order."""
    rows, malformed, host = [], 0, []
    for record in records:
        if record.direction != "rx":
            continue
        try:
            observation = parse_observation(record.payload).observation
        except ProtocolError:
            malformed += 1
            continue
        rows.append((observation.millis, observation.position_counts, observation.servo_counts,
                     observation.omega_rev_s))
        host.append(record.t_s)
    data = np.array(rows, dtype=float).reshape(-1, 4)
    return Readings(data[:, 0], data[:, 1].astype(int), data[:, 2].astype(int), data[:, 3], np.array(host),
                    malformed)
