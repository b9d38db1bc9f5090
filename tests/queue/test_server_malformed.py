"""Malformed requests to the queue (bad JSON, huge or missing bodies, bad ids, paths that climb out, garbage
on the wire) get one line of JSON with the right status, never a traceback, and change nothing stored; the
server goes on answering."""

import base64
import json

import pytest
import sqlalchemy as sa

from tests.queue.serving import TOKENS, one_line_error, served_queue

pytest.importorskip("sqlalchemy")
JSON = {"Content-Type": "application/json"}


@pytest.fixture
def queue(tmp_path):
    with served_queue(tmp_path, max_upload_bytes=64 * 1024) as served:
        yield served


def stored(store) -> tuple:
    """Everything a request could have changed."""
    from pendkit.queue.store import jobs, results, rigs, teams

    with store.engine.connect() as db:
        return tuple(tuple(tuple(row) for row in db.execute(sa.select(table)))
                     for table in (teams, jobs, rigs, results))


BAD_JOBS = [  # (body, headers, status, words in the refusal)
    (b"{not json", JSON, 400, "not JSON"),
    (b"[1, 2]", JSON, 400, "JSON object"),
    (b'{"kind": "controller", "options": {"episodes": NaN}}', JSON, 400, "NaN"),
    (b'{"kind": "blob", "payload_base64": "***not base64***"}', JSON, 400, "base64"),
    (b'{"kind": "blob", "payload_base64": 12}', JSON, 400, "base64"),
    (b'{"options": {}}', JSON, 400, "kind"),
    (b'{"kind": "controller", "options": "energy"}', JSON, 400, "JSON object"),
    (b'{"kind": "controller", "priority": 5}', JSON, 403, "only the instructor"),
    (b'{"kind": "controller", "priority": true}', JSON, 400, "whole number"),
    (b'{"kind": "controller", "time_limit_s": 100}', JSON, 400, "go in options"),
    (b'{"kind": "controller", "options": {"controller": "energy", "time_limit_s": 1e9}}', JSON, 400, "time_limit_s"),
    (b'{"kind": "controller", "options": {"controller": "bang-bang"}}', JSON, 400, "controller must be one of"),
    (b'{"kind": "rocket", "options": {}}', JSON, 400, "unknown job kind"),
    (b'{"kind": "blob", "payload_base64": "AAAA"}', JSON, 400, "device's checks"),
    (b"[" * 100_000 + b"]" * 100_000, JSON, 413, "at most"),
    (b"[" * 30_000 + b"]" * 30_000, JSON, 400, "not JSON"),  # deep enough to exhaust the parser's recursion
    (b"kind=controller", {"Content-Type": "application/x-www-form-urlencoded"}, 415, "multipart"),
    (b"--x\r\nContent-Disposition: form-data; name=\"kind\"\r\n\r\nblob\r\n--x--\r\n",
     {"Content-Type": "multipart/form-data"}, 400, "boundary"),
    (b"--x\r\nContent-Disposition: form-data; name=\"evil\"\r\n\r\n1\r\n--x--\r\n",
     {"Content-Type": "multipart/form-data; boundary=x"}, 400, "unknown field"),
    (b"--x\r\nContent-Disposition: form-data; name=\"options\"\r\n\r\n{bad\r\n--x--\r\n",
     {"Content-Type": "multipart/form-data; boundary=x"}, 400, "not JSON"),
    (b"--x\r\nContent-Disposition: form-data; name=\"priority\"\r\n\r\nhigh\r\n--x--\r\n",
     {"Content-Type": "multipart/form-data; boundary=x"}, 400, "must be a number"),
]


@pytest.mark.parametrize(("body", "headers", "status", "says"), BAD_JOBS, ids=range(len(BAD_JOBS)))
def test_a_bad_job_request_is_one_line_and_stores_nothing(queue, body, headers, status, says):
    before = stored(queue.store)
    answer_status, _, answer = queue.call("POST", "/api/jobs", "team-a", body, headers)
    assert answer_status == status and says in one_line_error(answer)
    assert stored(queue.store) == before
    assert queue.json("GET", "/api/state")[0] == 200  # still answering


def test_a_huge_body_is_refused_before_it_is_read(queue):
    before = stored(queue.store)
    head = (b"POST /api/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
            b"Authorization: Bearer " + TOKENS["team-a"].encode() + b"\r\nContent-Length: 999999999999\r\n\r\n{")
    answer = queue.raw(head)  # the rest never comes: the server answers at once and closes
    status_line, _, rest = answer.partition(b"\r\n")
    assert status_line.startswith(b"HTTP/1.1 413") and b"Connection: close" in rest
    assert "at most 65536" in one_line_error(rest.split(b"\r\n\r\n", 1)[1])
    assert stored(queue.store) == before


@pytest.mark.parametrize(("headers", "status"), [({"Transfer-Encoding": "chunked"}, 411), ({}, 411)])
def test_a_body_without_a_length_is_refused(queue, headers, status):
    request = (b"POST /api/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nAuthorization: Bearer "
               + TOKENS["team-a"].encode() + b"\r\n" + b"".join(f"{k}: {v}\r\n".encode() for k, v in headers.items())
               + b"\r\n")
    answer = queue.raw(request)
    assert answer.startswith(f"HTTP/1.1 {status}".encode())
    assert "Content-Length" in one_line_error(answer.split(b"\r\n\r\n", 1)[1])


def test_a_body_sent_with_a_bad_token_is_not_read_as_the_next_request(queue):
    smuggled = b"DELETE /api/jobs/1 HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + TOKENS["team-a"].encode()
    body = smuggled + b"\r\n\r\n"
    queue.store.submit("team-a", "controller", {"controller": "energy"})
    request = (b"POST /api/jobs HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
               b"Authorization: Bearer wrong\r\nContent-Length: " + str(len(body)).encode() + b"\r\n\r\n" + body)
    answer = queue.raw(request)
    assert answer.startswith(b"HTTP/1.1 401") and answer.count(b"HTTP/1.1 ") == 1
    assert queue.store.job(1).state == "waiting"


@pytest.mark.parametrize("path", ["/api/jobs/abc", "/api/jobs/-1", "/api/jobs/1.5", "/api/jobs/" + "9" * 40,
                                  "/api/jobs/1/../../../etc/passwd", "/api/jobs/1/%2e%2e/plot.png",
                                  "/jobs/../pendkit/queue/server.py", "/assets/../server.py", "/assets/%2e%2e/store.py",
                                  "//etc/passwd", "/api/jobs/1/summary.json", "/api/jobs/1/plot.png/x"])
def test_bad_ids_and_climbing_paths_are_404(queue, path):
    queue.store.submit("team-a", "controller", {"controller": "energy"})
    status, _, body = queue.call("GET", path, "team-a")
    assert status == 404
    error = one_line_error(body)
    assert "import" not in error and "/etc" not in error


GARBAGE = [b"GARBAGE\r\n\r\n", b"GET / HTTP/9.9\r\n\r\n", b"\x16\x03\x01\x02\x00\x01\r\n\r\n",
           b"GET /" + b"a" * 70_000 + b" HTTP/1.1\r\n\r\n", b"BREW /api/jobs HTTP/1.1\r\nHost: x\r\n\r\n"]


@pytest.mark.parametrize("request_bytes", GARBAGE, ids=range(len(GARBAGE)))
def test_garbage_on_the_wire_is_one_line_of_json(queue, request_bytes):
    answer = queue.raw(request_bytes)
    head, _, body = answer.partition(b"\r\n\r\n")
    assert head.split(b" ")[1][:1] in (b"4", b"5"), head
    one_line_error(body)
    assert "Traceback" not in "\n".join(queue.log)
    assert queue.json("GET", "/api/state")[0] == 200


def test_a_job_with_too_many_waiting_is_refused(queue):
    from pendkit.queue.server import MAX_WAITING_PER_TEAM

    for _ in range(MAX_WAITING_PER_TEAM):
        queue.store.submit("team-a", "controller", {"controller": "energy"})
    before = stored(queue.store)
    status, _, body = queue.call("POST", "/api/jobs", "team-a", json.dumps({"kind": "excitation"}).encode(), JSON)
    assert status == 429 and "cancel one" in one_line_error(body)
    assert stored(queue.store) == before


def test_a_payload_too_large_in_base64_is_refused(queue):
    payload = base64.b64encode(b"\0" * 70_000).decode()
    status, _, body = queue.call("POST", "/api/jobs", "team-a",
                                 json.dumps({"kind": "blob", "payload_base64": payload}).encode(), JSON)
    assert status == 413 and "65536" in one_line_error(body)
