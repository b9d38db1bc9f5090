"""A team's side of the queue over HTTP (the standard library's urllib): submit, follow, fetch results,
cancel. The same calls serve `pendkit queue submit/status/result/cancel` and a notebook:

    from pendkit.queue.client import QueueClient
    queue = QueueClient("http://10.0.0.5:8790", token_file="host-r03.txt")
    job = queue.submit_controller("energy", episodes=10)
    queue.wait(job)["figures"]

The token comes from `token_file` (its first line) or PENDKIT_QUEUE_TOKEN, never from a command line, and
goes only into the `Authorization` header.
"""

from __future__ import annotations

import base64
import json
import os
import ssl
import time
import urllib.error
import urllib.request
from collections.abc import Callable
from pathlib import Path

from pendkit.errors import ConfigError, PendkitError
from pendkit.safe_write import write_bytes, write_text

DEFAULT_SERVER = "http://127.0.0.1:8790"
TOKEN_VARIABLE = "PENDKIT_QUEUE_TOKEN"
SERVER_VARIABLE = "PENDKIT_QUEUE_SERVER"
FINISHED = ("done", "failed", "cancelled")


class QueueRequestError(PendkitError):
    """The server refused a request (its one line and status), or could not be reached (status 0)."""

    def __init__(self, message: str, status: int = 0) -> None:
        super().__init__(message)
        self.status = status


def read_token_file(path: str | Path) -> str:
    """The first line of a login file (broker-config's logins/host-rNN.txt)."""
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as error:
        raise ConfigError(f"cannot read the token file {path}: {error}") from None
    if not lines or not lines[0].strip():
        raise ConfigError(f"{path} is empty: its first line is the team's token")
    return lines[0].strip()


class QueueClient:
    """One team's client. `token`: given here (a notebook), else from `token_file`, else PENDKIT_QUEUE_TOKEN.
    `tls_ca`: the classroom CA (broker/ca.crt) for an https server."""

    def __init__(self, server: str | None = None, token: str | None = None, token_file: str | Path | None = None,
                 timeout_s: float = 30.0, tls_ca: str | Path | None = None) -> None:
        self.server = (server or os.environ.get(SERVER_VARIABLE) or DEFAULT_SERVER).rstrip("/")
        if not self.server.startswith(("http://", "https://")):
            raise ConfigError(f"the queue's server must look like http://HOST:PORT, got {self.server!r}")
        if token is None and token_file is not None:
            token = read_token_file(token_file)
        self._token = token if token is not None else os.environ.get(TOKEN_VARIABLE)
        self.timeout_s = timeout_s
        self._context = ssl.create_default_context(cafile=str(tls_ca)) if tls_ca is not None else None

    def __repr__(self) -> str:
        return f"QueueClient({self.server!r})"  # never the token

    # --- jobs ---
    def submit(self, kind: str, options: dict | None = None, payload: bytes | None = None, priority: int = 0,
               time_limit_s: float | None = None) -> int:
        """Queue a job; its id."""
        request = {"kind": kind, "options": dict(options or {})}
        if payload is not None:
            request["payload_base64"] = base64.b64encode(payload).decode("ascii")
        if priority:
            request["priority"] = priority
        if time_limit_s is not None:  # in the job's rig seconds
            request["options"]["time_limit_s"] = time_limit_s
        return int(self._json("POST", "/api/jobs", request)["id"])

    def submit_controller(self, controller: str, preset: str | None = None, params: dict | None = None,
                          episodes: int | None = None, episode_steps: int | None = None, **kwargs) -> int:
        """The kit's energy or trajopt swing-up, designed for a servo preset or a rig's RigParams dict."""
        options = {"controller": controller}
        options.update({key: value for key, value in (("preset", preset), ("params", params), ("episodes", episodes),
                                                       ("episode_steps", episode_steps)) if value is not None})
        return self.submit("controller", options, **kwargs)

    def submit_blob(self, blob: str | Path | bytes, **kwargs) -> int:
        """A device blob (`pendkit export`'s .pkcb), checked by the device's own checks before it is queued."""
        data = blob if isinstance(blob, bytes) else Path(blob).read_bytes()
        return self.submit("blob", {}, data, **kwargs)

    def submit_policy(self, name: str, **kwargs) -> int:
        return self.submit("policy", {"policy": name}, **kwargs)

    def submit_excitation(self, **kwargs) -> int:
        """`pendkit adapt`'s excitation recorded on a rig; the recording comes back as the telemetry."""
        return self.submit("excitation", {}, **kwargs)

    def jobs(self) -> list[dict]:
        """The team's own jobs."""
        return self._json("GET", "/api/jobs")["jobs"]

    def job(self, job_id: int) -> dict:
        return self._json("GET", f"/api/jobs/{int(job_id)}")

    def cancel(self, job_id: int) -> dict:
        return self._json("DELETE", f"/api/jobs/{int(job_id)}")

    def telemetry_csv(self, job_id: int) -> str:
        return self._request("GET", f"/api/jobs/{int(job_id)}/telemetry.csv")[1].decode("utf-8")

    def plot_png(self, job_id: int) -> bytes:
        return self._request("GET", f"/api/jobs/{int(job_id)}/plot.png")[1]

    def wait(self, job_id: int, timeout_s: float | None = None, poll_s: float = 2.0,
             on_change: Callable[[dict], None] | None = None) -> dict:
        """The job once it has finished (done, failed or cancelled); `on_change` sees each new state."""
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        last = None
        while True:
            job = self.job(job_id)
            if on_change is not None and (job["state"], job.get("rig")) != last:
                on_change(job)
                last = (job["state"], job.get("rig"))
            if job["state"] in FINISHED:
                return job
            if deadline is not None and time.monotonic() >= deadline:
                raise QueueRequestError(f"job {job_id} is still {job['state']} after {timeout_s:g} s")
            time.sleep(poll_s)

    def download(self, job_id: int, out_dir: str | Path) -> dict[str, Path]:
        """The job's summary (job-N.json), telemetry (CSV) and plot (PNG), as far as it has them, and an
        excitation's recordings (job-N-excitation.json), into `out_dir`."""
        job = self.job(job_id)
        if job["state"] not in FINISHED:
            raise QueueRequestError(f"job {job_id} is {job['state']}: its result comes when it has run "
                                    f"(`pendkit queue status {job_id} --wait`)")
        out = Path(out_dir)
        written = {"job": write_text(out / f"job-{job_id}.json", json.dumps(job, indent=1) + "\n", base=out)}
        if job.get("telemetry"):
            written["telemetry"] = write_text(out / f"job-{job_id}-telemetry.csv", self.telemetry_csv(job_id),
                                              base=out)
        if job.get("plot"):
            written["plot"] = write_bytes(out / f"job-{job_id}-plot.png", self.plot_png(job_id), base=out)
        if isinstance(job.get("summary"), dict) and "excitation" in job["summary"]:
            # the recordings as `pendkit adapt` writes its excitation.json, for identification on the laptop
            written["excitation"] = write_text(out / f"job-{job_id}-excitation.json",
                                               json.dumps(job["summary"]["excitation"]), base=out)
        return written

    # --- public ---
    def state(self) -> dict:
        """Every rig and job, as the class page shows them (no token needed)."""
        return self._json("GET", "/api/state", token=False)

    def leaderboard(self) -> list[dict]:
        return self._json("GET", "/api/leaderboard", token=False)["leaderboard"]

    # --- the wire ---
    def _json(self, method: str, path: str, body: dict | None = None, token: bool = True):
        data = None if body is None else json.dumps(body).encode()
        return json.loads(self._request(method, path, data, token)[1])

    def _request(self, method: str, path: str, data: bytes | None = None, token: bool = True) -> tuple[int, bytes]:
        headers = {"Accept": "application/json"}
        if data is not None:
            headers["Content-Type"] = "application/json"
        if token:
            if not self._token:
                raise ConfigError(f"no team token: set {TOKEN_VARIABLE} or give a token file (your team's "
                                  "logins/host-rNN.txt)")
            headers["Authorization"] = f"Bearer {self._token}"
        request = urllib.request.Request(self.server + path, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(request, timeout=self.timeout_s, context=self._context) as response:
                return response.status, response.read()
        except urllib.error.HTTPError as error:
            raise QueueRequestError(_refusal(error), error.code) from None
        except (urllib.error.URLError, OSError) as error:
            reason = getattr(error, "reason", error)
            raise QueueRequestError(f"cannot reach the queue at {self.server} ({reason}): is `pendkit queue serve` "
                                    f"running there? (--server or {SERVER_VARIABLE})") from None


def _refusal(error: urllib.error.HTTPError) -> str:
    """The server's one line, or its status when the answer is not the queue's JSON."""
    try:
        return f"the queue refused ({error.code}): {json.loads(error.read())['error']}"
    except (ValueError, KeyError, TypeError, OSError):
        return f"the queue answered {error.code} {error.reason}"
