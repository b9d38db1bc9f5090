"""`pendkit queue serve`: the queue's JSON API and class page over a `QueueStore`.

The standard library's `ThreadingHTTPServer` is enough: a class polls a handful of small routes every 2 s, and
the server holds no state of its own (the database does), so a web framework would add a dependency, not a
feature. A team's token arrives as `Authorization: Bearer TOKEN` and is looked up by its digest (the store keeps
no token); it is never echoed, never logged (a log line names the route, not the path), never in a URL.
Every refusal is one line of JSON, `{"error": "..."}`, with its status; nothing is written before a request
has passed every check. No file is served from disk: the page's three files live in `page.py`.
"""

from __future__ import annotations

import base64
import binascii
import json
import re
import ssl
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import urlsplit

import sqlalchemy as sa

from pendkit.errors import PendkitError
from pendkit.queue import page, views
from pendkit.queue.http_bodies import HttpError, json_object, multipart_fields
from pendkit.queue.store import QueueStore

# pendkit modules that load torch and MuJoCo are imported inside the functions that use them: importing this module
# does not need them (start-up; torch is an optional extra).

DEFAULT_PORT = 8790
MAX_UPLOAD_BYTES = 1024 * 1024  # a device blob is a few kB; a run's weights well under this
MAX_WAITING_PER_TEAM = 10  # a team's waiting jobs: more are refused until some have run
MAX_PRIORITY = 10
REQUEST_TIMEOUT_S = 30.0  # a client that stops sending mid-request is dropped after this
JOB_ROUTE = re.compile(r"/api/jobs/(\d{1,12})(?:/(telemetry\.csv|plot\.png))?")
PAGE_ROUTE = re.compile(r"/jobs/(\d{1,12})")
SECURITY_HEADERS = {
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "X-Frame-Options": "DENY",
    "Content-Security-Policy": "default-src 'self'; img-src 'self' blob:; script-src 'self'; style-src 'self'; "
                               "frame-ancestors 'none'; base-uri 'none'; form-action 'none'",
}


@dataclass
class Reply:
    status: int
    body: bytes
    content_type: str = "application/json"
    headers: dict = field(default_factory=dict)


def json_reply(value, status: int = 200, **headers) -> Reply:
    return Reply(status, (json.dumps(value, separators=(",", ":")) + "\n").encode(), headers=headers)


class QueueServer:
    """The API over `store`, served on `bind:port` (port 0: a free one). `log` takes one line per request.
    `tls`: (certificate, key) files, e.g. broker-config's server.crt and server.key, for https."""

    def __init__(self, store: QueueStore, bind: str = "127.0.0.1", port: int = DEFAULT_PORT,
                 max_upload_bytes: int = MAX_UPLOAD_BYTES, log: Callable[[str], None] | None = None,
                 tls: tuple[str, str] | None = None) -> None:
        self.store = store
        self.max_upload_bytes = max_upload_bytes
        self.log = log or (lambda line: print(line, file=sys.stderr, flush=True))
        handler = type("Handler", (_Handler,), {"queue": self})
        self.httpd = _Server((bind, port), handler)
        self.httpd.log = self.log
        self.scheme = "http"
        if tls is not None:
            context = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
            context.load_cert_chain(*tls)
            # the handshake runs in the request's thread (on first read), not in the accepting loop
            self.httpd.socket = context.wrap_socket(self.httpd.socket, server_side=True,
                                                    do_handshake_on_connect=False)
            self.scheme = "https"
        self._thread: threading.Thread | None = None
        self._team_locks: dict[str, threading.Lock] = {}
        self._locks_lock = threading.Lock()

    @property
    def url(self) -> str:
        host, port = self.httpd.server_address[:2]
        return f"{self.scheme}://{host}:{port}"

    def serve_forever(self) -> None:
        self.httpd.serve_forever(poll_interval=0.2)

    def start(self) -> QueueServer:
        """Serve on a thread of its own (tests, notebooks)."""
        self._thread = threading.Thread(target=self.serve_forever, name="queue-server", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        if self._thread is not None:
            self.httpd.shutdown()
            self._thread.join()
        self.httpd.server_close()

    def __enter__(self) -> QueueServer:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    # --- the API: each returns a Reply or raises HttpError ---
    def team_for(self, token: str | None) -> tuple[str, bool]:
        if not token:
            raise HttpError(401, "send your team's token as `Authorization: Bearer TOKEN`")
        found = self.store.team_for_token(token)
        if found is None:
            raise HttpError(401, "that token is not a team's: use the login file your instructor gave you")
        return found

    def own_job(self, job_id: int, team: str):
        job = self.store.job(job_id, team)
        if job is None:  # another team's job looks exactly like a missing one
            raise HttpError(404, f"no job {job_id} of team {team}")
        return job

    def submit(self, team: str, instructor: bool, fields: dict, payload: bytes | None) -> Reply:
        unknown = sorted(set(fields) - {"kind", "options", "priority"})
        if unknown:
            raise HttpError(400, f"unknown field {unknown[0][:40]!r}: a job is kind, options, priority and its "
                                 "payload; episodes and time_limit_s go in options")
        kind, options = fields.get("kind"), fields.get("options", {})
        if not isinstance(kind, str) or not kind:
            raise HttpError(400, "say which kind of job: \"kind\": controller, blob, policy or excitation")
        if not isinstance(options, dict):
            raise HttpError(400, f"\"options\" must be a JSON object, got {type(options).__name__}")
        priority = fields.get("priority", 0)
        if isinstance(priority, bool) or not isinstance(priority, int) or abs(priority) > MAX_PRIORITY:
            raise HttpError(400, f"\"priority\" must be a whole number from {-MAX_PRIORITY} to {MAX_PRIORITY}")
        if priority and not instructor:
            raise HttpError(403, "only the instructor sets a priority: leave it out")
        from pendkit.queue.jobs import submit_job  # the device's own checks: imported with the first job

        with self._locks_lock:
            team_lock = self._team_locks.setdefault(team, threading.Lock())
        with team_lock:  # a team's jobs one at a time, so two at once cannot pass the cap together
            if len(self.store.jobs(team, ("waiting",))) >= MAX_WAITING_PER_TEAM:
                raise HttpError(429, f"team {team} has {MAX_WAITING_PER_TEAM} jobs waiting already: wait for some "
                                     "to run, or cancel one")
            try:  # checked (make_job) before anything is stored; the job's time limit is its options'
                job_id = submit_job(self.store, team, kind, options, payload, priority)
            except (PendkitError, ValueError) as error:
                raise HttpError(400, str(error).splitlines()[0] if str(error) else type(error).__name__) from None
        return json_reply({"id": job_id, "state": "waiting", "page": f"/jobs/{job_id}"}, 201,
                          Location=f"/api/jobs/{job_id}")

    def job_reply(self, job_id: int, team: str, part: str | None) -> Reply:
        job = self.own_job(job_id, team)
        result = self.store.result(job_id) if job.state in views.FINISHED else None
        if part is None:
            return json_reply(views.job_view(job, result))
        if part == "telemetry.csv":
            if result is None or not result["telemetry_csv"]:
                raise HttpError(404, f"job {job_id} has no telemetry yet (it is {job.state})")
            return Reply(200, result["telemetry_csv"].encode(), "text/csv; charset=utf-8",
                         {"Content-Disposition": f'attachment; filename="job-{job_id}-telemetry.csv"'})
        if result is None or not result["plot_png"]:
            raise HttpError(404, f"job {job_id} has no plot yet (it is {job.state})")
        return Reply(200, result["plot_png"], "image/png")

    def cancel(self, job_id: int, team: str, instructor: bool) -> Reply:
        job = self.store.job(job_id, None if instructor else team)
        if job is None:
            raise HttpError(404, f"no job {job_id} of team {team}")
        if not self.store.cancel(job_id, None if instructor else team):
            raise HttpError(409, f"job {job_id} is {self.store.job(job_id).state}: only a waiting or running job "
                                 "can be cancelled")
        return json_reply({"id": job_id, "state": "cancelled"})


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    log: Callable[[str], None]

    def handle_error(self, request, client_address) -> None:
        """A connection that broke (a failed TLS handshake, a reset) is one line, never a traceback."""
        error = sys.exc_info()[1]
        self.log(f"{_now()} {client_address[0]} connection dropped: {type(error).__name__}")


class _Handler(BaseHTTPRequestHandler):
    server_version = "pendkit-queue"
    sys_version = ""
    protocol_version = "HTTP/1.1"
    timeout = REQUEST_TIMEOUT_S
    queue: QueueServer

    def setup(self) -> None:
        super().setup()
        if isinstance(self.connection, ssl.SSLSocket):
            self.connection.do_handshake()  # here, in the request's thread, within `timeout`

    def do_GET(self) -> None:
        self._answer("GET")

    def do_POST(self) -> None:
        self._answer("POST")

    def do_DELETE(self) -> None:
        self._answer("DELETE")

    def _answer(self, method: str) -> None:
        self._body_read, self._route, self._team = False, "unknown route", None
        try:
            reply = self._route_request(method, urlsplit(self.path).path)
        except HttpError as error:
            reply = json_reply({"error": str(error)}, error.status)
            if error.status == 401:
                reply.headers["WWW-Authenticate"] = 'Bearer realm="pendkit queue"'
        except sa.exc.OperationalError:
            reply = json_reply({"error": "the queue's database is busy or unreachable: try again in a moment"}, 503)
        except Exception as error:  # noqa: BLE001 - a bug answers one line, never a traceback
            self.queue.log(f"{_now()} error in {method} {self._route}: {type(error).__name__}")
            reply = json_reply({"error": f"internal error ({type(error).__name__}): the instructor can see the "
                                         "server's log"}, 500)
        if self._unread_body():
            self.close_connection = True  # what the client sent would be read as its next request
        if self.close_connection:
            reply.headers["Connection"] = "close"
        self._send(reply)
        who = f" team={self._team}" if self._team else ""
        self.queue.log(f"{_now()} {self.client_address[0]} {method} {self._route} {reply.status}{who}")

    def _route_request(self, method: str, path: str) -> Reply:
        if method == "GET" and path in ("/", "/index.html"):
            self._route = "/"
            return Reply(200, page.CLASS_PAGE.encode(), "text/html; charset=utf-8")
        if method == "GET" and path in page.ASSETS:
            self._route = path
            body, kind = page.ASSETS[path]
            return Reply(200, body.encode(), kind)
        if method == "GET" and (match := PAGE_ROUTE.fullmatch(path)):
            self._route = "/jobs/{id}"
            return Reply(200, page.job_page(int(match.group(1))).encode(), "text/html; charset=utf-8")
        if method == "GET" and path == "/api/state":
            self._route = path
            return json_reply(views.public_state(self.queue.store))
        if method == "GET" and path == "/api/leaderboard":
            self._route = path
            return json_reply({"leaderboard": views.leaderboard(self.queue.store)})
        if path == "/api/jobs":
            self._route = path
            if method not in ("GET", "POST"):
                raise HttpError(405, f"{method} /api/jobs: use GET (your jobs) or POST (a new job)")
            team, instructor = self._authorised()
            if method == "GET":
                return json_reply({"jobs": views.team_jobs(self.queue.store, team)})
            return self.queue.submit(team, instructor, *self._job_request())
        if match := JOB_ROUTE.fullmatch(path):
            job_id, part = int(match.group(1)), match.group(2)
            self._route = f"/api/jobs/{{id}}{'/' + part if part else ''}"
            if method not in ("GET", "DELETE") or (method == "DELETE" and part):
                raise HttpError(405, f"{method} {self._route}: use GET, or DELETE /api/jobs/ID to cancel")
            team, instructor = self._authorised()
            if method == "DELETE":
                return self.queue.cancel(job_id, team, instructor)
            return self.queue.job_reply(job_id, team, part)
        if path.startswith("/api/jobs/") or path.startswith("/jobs/"):
            raise HttpError(404, "a job's id is a whole number: /api/jobs/ID")
        raise HttpError(404 if method == "GET" else 405, f"no {method} {'route' if method == 'GET' else 'here'}: "
                        "the API is under /api (state, leaderboard, jobs), the class page at /")

    def _authorised(self) -> tuple[str, bool]:
        self._team, instructor = self.queue.team_for(self._token())
        return self._team, instructor

    def _token(self) -> str | None:
        header = self.headers.get("Authorization", "")
        scheme, _, token = header.partition(" ")
        return token.strip() if scheme.lower() == "bearer" else None

    def _body(self) -> bytes:
        length = self.headers.get("Content-Length", "")
        if "Transfer-Encoding" in self.headers or not length.isdigit():
            self.close_connection = True  # where its body ends is unknown
            raise HttpError(411, "send a job's body with a Content-Length (not chunked)")
        size = int(length)
        if size > self.queue.max_upload_bytes:
            raise HttpError(413, f"the request is {size} bytes; the queue takes at most "
                                 f"{self.queue.max_upload_bytes} (a device blob is a few kB)")
        body = self.rfile.read(size)
        self._body_read = True
        if len(body) != size:
            self.close_connection = True
            raise HttpError(400, f"the body ended after {len(body)} of {size} bytes")
        return body

    def _unread_body(self) -> bool:
        length = self.headers.get("Content-Length", "0") if self.headers else "0"
        return not self._body_read and (length != "0" or "Transfer-Encoding" in (self.headers or {}))

    def _job_request(self) -> tuple[dict, bytes | None]:
        """(fields, payload) of a new job: JSON with `payload_base64`, or multipart with a `payload` file."""
        kind = self.headers.get_content_type()
        if kind not in ("application/json", "multipart/form-data"):
            raise HttpError(415, f"a job is sent as application/json or multipart/form-data, not {kind}")
        body = self._body()
        if kind == "application/json":
            fields = json_object(body, "the body")
            encoded = fields.pop("payload_base64", None)
            if encoded is None:
                return fields, None
            if not isinstance(encoded, str):
                raise HttpError(400, "\"payload_base64\" must be a base64 string")
            try:
                return fields, base64.b64decode(encoded, validate=True)
            except (binascii.Error, ValueError):
                raise HttpError(400, "\"payload_base64\" is not valid base64") from None
        return multipart_fields(self.headers.get("Content-Type", ""), body)

    def _send(self, reply: Reply) -> None:
        try:
            self.send_response(reply.status)
            headers = {"Content-Type": reply.content_type, "Content-Length": str(len(reply.body)),
                       "Cache-Control": "no-store", **SECURITY_HEADERS, **reply.headers}
            for name, value in headers.items():
                self.send_header(name, value)
            self.end_headers()
            if self.command != "HEAD":
                self.wfile.write(reply.body)
        except (BrokenPipeError, ConnectionResetError, TimeoutError, ssl.SSLError):
            self.close_connection = True

    def send_error(self, code: int, message: str | None = None, explain: str | None = None) -> None:
        """The standard library's refusals (a garbled request line, an unknown method, huge headers) as one
        line of JSON too; the request itself is never logged."""
        self.close_connection = True
        if self.request_version not in ("HTTP/1.0", "HTTP/1.1"):
            self.request_version = "HTTP/1.1"  # a request line we could not read still gets a status line
        said = {501: "that method is not served here: use GET, POST or DELETE",
                414: "the request's address is too long", 431: "the request's headers are too large"}
        self._send(json_reply({"error": said.get(code, f"malformed request ({code}): send HTTP/1.1")}, code,
                              Connection="close"))
        self.queue.log(f"{_now()} {self.client_address[0]} malformed request {code}")

    def log_message(self, format: str, *args) -> None:
        """Silent: `_answer` logs one line without the path, the headers or the body."""


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S")
