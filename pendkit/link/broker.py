"""Brokers: an embedded pure-Python one (amqtt) for a laptop, and Mosquitto for classrooms and CI.

`write_classroom_config` writes a Mosquitto configuration for a room of rigs: no anonymous clients, one
user per rig device (`r01`), one per student host (`host-r01`) and an instructor who can read everything,
an ACL so that each user reaches only its own rig's topics, and TCP_NODELAY on.
"""

from __future__ import annotations

import asyncio
import csv
import io
import logging
import os
import secrets
import shutil
import socket
import subprocess
import threading
import time
from pathlib import Path

from pendkit.errors import ConfigError, PendkitError
from pendkit.link.secret_files import mosquitto_hash, write_private
from pendkit.link.tls import make_classroom_ca


def free_port(host: str = "127.0.0.1") -> int:
    with socket.socket() as probe:
        probe.bind((host, 0))
        return probe.getsockname()[1]


def wait_for_port(host: str, port: int, timeout_s: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            with socket.create_connection((host, port), timeout=0.2):
                return True
        except OSError:
            time.sleep(0.02)
    return False


class _DroppedAtShutdown(logging.Filter):
    """Leaves out amqtt's "N messages not broadcasted" warning, which a stopping broker prints for the messages
    still queued (a stray line under a notebook cell)."""

    def filter(self, record: logging.LogRecord) -> bool:
        return "messages not broadcasted" not in record.getMessage()


class EmbeddedBroker:
    """amqtt in a background thread, bound to loopback by default. Use as a context manager."""

    def __init__(self, host: str = "127.0.0.1", port: int = 1883) -> None:
        self.host, self.port = host, port
        self._loop: asyncio.AbstractEventLoop | None = None
        self._broker = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None

    @property
    def url(self) -> str:
        return f"mqtt://{self.host}:{self.port}"

    def config(self) -> dict:
        return {"listeners": {"default": {"type": "tcp", "bind": f"{self.host}:{self.port}"}},
                "plugins": {"amqtt.plugins.authentication.AnonymousAuthPlugin": {"allow_anonymous": True}}}

    def _check_port_free(self) -> None:
        """Say plainly that the port is taken (amqtt logs a traceback and a vaguer message)."""
        with socket.socket(socket.AF_INET6 if ":" in self.host else socket.AF_INET) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as asyncio's server will
            try:
                probe.bind((self.host, self.port))
            except OSError as error:
                raise PendkitError(f"the embedded broker cannot listen on {self.host}:{self.port}: {error.strerror} "
                                   "(another broker, such as Mosquitto, on that port? stop it, or pass --port)") \
                    from None

    def start(self, timeout_s: float = 10.0) -> EmbeddedBroker:
        try:
            from amqtt.broker import Broker
        except ImportError as error:
            raise PendkitError("the embedded broker needs amqtt: pip install amqtt") from error
        self._check_port_free()

        def serve() -> None:
            self._loop = asyncio.new_event_loop()
            asyncio.set_event_loop(self._loop)
            try:
                self._broker = Broker(self.config(), loop=self._loop)
                self._loop.run_until_complete(self._broker.start())
            except BaseException as error:  # reported to the starting thread
                self._error = error
                self._ready.set()
                return
            self._ready.set()
            self._loop.run_forever()

        self._thread = threading.Thread(target=serve, daemon=True, name="pendkit-broker")
        self._thread.start()
        if not self._ready.wait(timeout_s) or self._error is not None:
            raise PendkitError(f"the embedded broker did not start on {self.host}:{self.port}: {self._error}")
        return self  # listening once start() has returned

    def stop(self) -> None:
        if self._loop is None or self._broker is None:
            return
        future = asyncio.run_coroutine_threadsafe(self._broker.shutdown(), self._loop)
        quiet = _DroppedAtShutdown()  # telemetry still in flight when a lab stops its rig: dropped on purpose
        logging.getLogger("amqtt.broker").addFilter(quiet)
        try:
            future.result(timeout=5)
        except Exception:  # shutting down anyway
            pass
        finally:
            logging.getLogger("amqtt.broker").removeFilter(quiet)
        self._loop.call_soon_threadsafe(self._loop.stop)
        if self._thread is not None:
            self._thread.join(timeout=5)
        self._loop = self._broker = None

    def __enter__(self) -> EmbeddedBroker:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


RESERVED_USERS = ("instructor",)


def read_credentials(path: str | Path) -> dict[str, str]:
    """user -> password from a credentials.csv that `write_classroom_config` wrote ({} if there is none)."""
    path = Path(path)
    if not path.exists():
        return {}
    try:
        with path.open(newline="") as handle:
            reader = csv.DictReader(handle)
            if reader.fieldnames is not None and not {"user", "password"} <= set(reader.fieldnames):
                raise KeyError("its first line is not user,password,role: the hashed `passwords` file or a single "
                               "login is not it")
            return {row["user"]: row["password"] for row in reader if row.get("user")}
    except (OSError, KeyError, csv.Error, UnicodeDecodeError) as error:
        raise ConfigError(f"{path} is not the credentials file broker-config writes ({error}): move it away or "
                          "pass another --out") from None


def write_classroom_config(rigs: list[str], out_dir: str | Path, port: int = 1883, bind: str = "0.0.0.0",
                           passwords: dict[str, str] | None = None, tls_port: int | None = None,
                           addresses: list[str] | None = None, new_ca: bool = False) -> dict[str, Path]:
    """mosquitto.conf, acl, passwords (hashed), credentials.csv (plain, 0600) and logins/USER.txt (each user's
    password alone, 0600, for `--password-file`).

    Users keep the passwords an earlier run gave them (credentials.csv in `out_dir`): adding a rig gives only
    the new users passwords. Client ids are the usernames (`use_username_as_clientid`), so no client can
    take over another's connection. With `tls_port`, a TLS listener too, with a CA made here (`tls.py`) and a
    server certificate naming this machine and `addresses`."""
    if not rigs or len(set(rigs)) != len(rigs) or not all(r.isalnum() for r in rigs):
        raise ConfigError(f"rig ids must be distinct and alphanumeric (r01, r02, ...), got {rigs}")
    reserved = [r for r in rigs if r.lower() in RESERVED_USERS]
    if reserved:
        raise ConfigError(f"{reserved[0]!r} is a user the broker keeps for itself: name the rig otherwise (r01, ...)")
    out = Path(out_dir).resolve()
    out.mkdir(parents=True, exist_ok=True)
    paths = {"conf": out / "mosquitto.conf", "acl": out / "acl", "passwords": out / "passwords",
             "credentials": out / "credentials.csv"}
    kept = read_credentials(paths["credentials"])
    passwords = {**kept, **(passwords or {})}
    users = [*rigs, *(f"host-{rig}" for rig in rigs), "instructor"]
    for user in users:
        passwords.setdefault(user, secrets.token_urlsafe(12))
    acl_lines = ["# Generated by `pendkit broker-config`: each user reaches only its own rig's topics."]
    for rig in rigs:
        # the rig may clear its own command topic (a retained command would move the arm at every boot)
        acl_lines += ["", f"user {rig}", f"topic write pendulum-r/obs/{rig}", f"topic write pendulum-r/status/{rig}",
                      f"topic readwrite pendulum-r/act/{rig}", f"topic read pendulum-r/ctl/{rig}",
                      "", f"user host-{rig}", f"topic write pendulum-r/act/{rig}", f"topic write pendulum-r/ctl/{rig}",
                      f"topic read pendulum-r/obs/{rig}", f"topic read pendulum-r/status/{rig}"]
    acl_lines += ["", "# the instructor reads every rig and may command any (a stop from the class dashboard)",
                  "user instructor", "topic read pendulum-r/#", "topic write pendulum-r/act/#",
                  "topic write pendulum-r/ctl/#", ""]
    paths["acl"].write_text("\n".join(acl_lines))
    everyone = list(dict.fromkeys([*users, *kept]))  # users of rigs configured before stay
    # hashed always (Mosquitto's own format), readable by the broker alone; the plain passwords only in
    # credentials.csv, the instructor's alone
    write_private(paths["passwords"], "".join(f"{user}:{mosquitto_hash(passwords[user])}\n" for user in everyone),
                  broker_reads=True)
    table = io.StringIO()
    writer = csv.writer(table)
    writer.writerow(["user", "password", "role"])
    for user in everyone:
        role = "instructor" if user == "instructor" else ("host" if user.startswith("host-") else "rig")
        writer.writerow([user, passwords[user], role])
    write_private(paths["credentials"], table.getvalue())
    paths["logins"] = out / "logins"  # one password per file, for --password-file: a team gets its own alone
    paths["logins"].mkdir(mode=0o700, exist_ok=True)
    for user in everyone:
        write_private(paths["logins"] / f"{user}.txt", passwords[user] + "\n")
    lines = [
        "# Generated by `pendkit broker-config`. Start with: mosquitto -c mosquitto.conf",
        "per_listener_settings false",
        f"listener {port} {bind}",
    ]
    if tls_port is not None:
        tls = make_classroom_ca(out, extra_names=addresses or [], new_ca=new_ca)
        paths.update(tls)
        lines += [f"listener {tls_port} {bind}", f"cafile {tls['ca']}", f"certfile {tls['cert']}",
                  f"keyfile {tls['key']}", "tls_version tlsv1.2"]
    lines += [
        "allow_anonymous false",
        f"password_file {paths['passwords']}",
        f"acl_file {paths['acl']}",
        "# A client's id is its username: no one can connect as another's id and knock it off the broker.",
        "use_username_as_clientid true",
        "# Without TCP_NODELAY steady streaming sees 13-32 ms p99 latency.",
        "set_tcp_nodelay true",
        "persistence false",
        "max_queued_messages 200",
        "",
    ]
    paths["conf"].write_text("\n".join(lines))
    return paths


def mosquitto_binary() -> str | None:
    """Debian's mosquitto, on the PATH or in /usr/sbin (outside root's PATH); None when not installed."""
    return shutil.which("mosquitto") or ("/usr/sbin/mosquitto" if Path("/usr/sbin/mosquitto").exists() else None)


class MosquittoBroker:
    """A Mosquitto process on a loopback port (tests, benchmarks); with `rigs`, the classroom config."""

    def __init__(self, work_dir: str | Path, port: int | None = None, rigs: list[str] | None = None) -> None:
        self.binary = mosquitto_binary()
        if self.binary is None:
            raise PendkitError("mosquitto is not installed: apt-get install mosquitto (or use EmbeddedBroker)")
        self.work_dir = Path(work_dir)
        self.port = port or free_port()
        self.rigs = rigs
        self.paths: dict[str, Path] = {}
        self.process: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        return f"mqtt://127.0.0.1:{self.port}"

    def credentials(self) -> dict[str, str]:
        with self.paths["credentials"].open() as handle:
            return {row["user"]: row["password"] for row in csv.DictReader(handle)}

    def start(self) -> MosquittoBroker:
        if self.rigs:
            self.paths = write_classroom_config(self.rigs, self.work_dir, self.port, "127.0.0.1")
        else:
            self.work_dir.mkdir(parents=True, exist_ok=True)
            self.paths = {"conf": self.work_dir / "mosquitto.conf"}
            self.paths["conf"].write_text(f"listener {self.port} 127.0.0.1\nallow_anonymous true\n"
                                          "set_tcp_nodelay true\npersistence false\n")
        if os.geteuid() == 0:
            # As root mosquitto drops to its own user, who cannot enter private temporary directories
            # (pytest's, CI's). This helper is for tests and benchmarks: stay root; classrooms do not.
            with self.paths["conf"].open("a") as conf:
                conf.write("user root\n")
        self.process = subprocess.Popen([self.binary, "-c", str(self.paths["conf"])], stdout=subprocess.DEVNULL,
                                        stderr=subprocess.PIPE)
        if not wait_for_port("127.0.0.1", self.port):
            self.stop()
            raise PendkitError(f"mosquitto did not start on port {self.port}")
        return self

    def stop(self) -> None:
        if self.process is not None:
            self.process.kill()
            self.process.wait(timeout=5)
            self.process = None

    def __enter__(self) -> MosquittoBroker:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
