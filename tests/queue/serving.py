"""A queue served for real on a free loopback port over an SQLite file, and plain HTTP calls to it, shared by
the server's tests and the browser test."""

from __future__ import annotations

import http.client
import json
import socket
from contextlib import contextmanager
from dataclasses import dataclass, field
from urllib.parse import urlsplit

import pytest

TOKENS = {"team-a": "token-of-team-a-7Qx", "team-b": "token-of-team-b-9Rz", "instructor": "token-of-instructor-3Kp"}


@dataclass
class Served:
    url: str
    store: object
    log: list[str] = field(default_factory=list)

    @property
    def port(self) -> int:
        return urlsplit(self.url).port

    def call(self, method: str, path: str, team: str | None = None, body: bytes | None = None,
             headers: dict | None = None) -> tuple[int, dict, bytes]:
        """(status, headers, body) of one request; `team` sends that team's token."""
        sent = dict(headers or {})
        if team is not None:
            sent["Authorization"] = f"Bearer {TOKENS[team]}"
        connection = http.client.HTTPConnection("127.0.0.1", self.port, timeout=30)
        try:
            connection.request(method, path, body=body, headers=sent)
            response = connection.getresponse()
            return response.status, dict(response.getheaders()), response.read()
        finally:
            connection.close()

    def json(self, method: str, path: str, team: str | None = None, body=None) -> tuple[int, dict]:
        data = None if body is None else json.dumps(body).encode()
        headers = {"Content-Type": "application/json"} if data is not None else {}
        status, _, answer = self.call(method, path, team, data, headers)
        return status, json.loads(answer)

    def raw(self, request: bytes) -> bytes:
        """Send bytes as they are; everything the server answers until it closes (or 10 s of silence)."""
        with socket.create_connection(("127.0.0.1", self.port), timeout=10) as connection:
            connection.sendall(request)
            answer = b""
            try:
                while chunk := connection.recv(65536):
                    answer += chunk
            except TimeoutError:
                pass
        return answer


@contextmanager
def served_queue(tmp_path, **options):
    """A store with two teams and the instructor, behind a QueueServer on a free port."""
    pytest.importorskip("sqlalchemy")
    from pendkit.queue.server import QueueServer
    from pendkit.queue.store import QueueStore

    store = QueueStore(str(tmp_path / "queue.db"))
    for team, token in TOKENS.items():
        store.add_team(team, token, instructor=team == "instructor")
    log: list[str] = []
    server = QueueServer(store, port=0, log=log.append, **options).start()
    try:
        yield Served(server.url, store, log)
    finally:
        server.close()
        store.close()


def one_line_error(body: bytes) -> str:
    """The refusal's text, checking it is one line of JSON and nothing else."""
    text = body.decode()
    assert text.endswith("\n") and text.count("\n") == 1, text
    assert "Traceback" not in text
    answer = json.loads(text)
    assert set(answer) == {"error"} and answer["error"], answer
    return answer["error"]


RESULT = {  # as the runner writes it (pendkit/queue/job_results.py)
    "kind": "controller", "rig": "r01", "verdict": "9/10", "solved": True, "held": 9, "episodes_run": 10,
    "time_to_upright_s": 1.84, "episode_steps": 500, "control_step_s": 0.06,
    "episodes": [{"held": index != 3, "steps": 500, "time_to_upright_s": 1.7 + index / 100 if index != 3 else None,
                  "held_fraction": 0.9 if index != 3 else 0.1, "flags": [] if index != 3 else ["overspin"]}
                 for index in range(10)],
    "pushes": {"verdict": "7/10", "held": 7, "episodes": 10, "solved": False, "time_to_upright_s": 2.1,
               "size": "hand", "per_episode": 2}}
VERDICT = "solved: 9/10 held"


def plot_png() -> bytes:
    """A small real plot, as a runner stores one."""
    import io

    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(3, 2))
    axes.plot([0, 1, 2, 3], [3.1, 2.0, 0.4, 0.0])
    axes.set_xlabel("time (s)")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    plt.close(figure)
    return buffer.getvalue()


def run_to_result(store, team: str, summary: dict = RESULT, csv: str = "time_s,theta_rad\n0.0,3.14\n",
                  png: bytes | None = None, rig: str = "r01") -> int:
    """A job of `team` taken by a rig and finished with `summary`, as a runner would; its id."""
    job_id = store.submit(team, "controller", {"controller": "energy"})
    store.register_rig(rig, "bench-1", None)
    claimed = store.claim(rig, "bench-1")
    assert claimed is not None and claimed.id == job_id, "another job was waiting"
    store.finish(job_id, summary, csv, plot_png() if png is None else png)
    return job_id
