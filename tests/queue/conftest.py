"""The queue's tests run on both databases it supports: an SQLite file and a real PostgreSQL server, started
here once per test session (per xdist worker) from Debian's package and stopped at its end.

`queue_url` gives each test a fresh, empty database of either kind. Without PostgreSQL or psycopg the
PostgreSQL half skips with the command that installs them (tests/system_needs.py)."""

from __future__ import annotations

import itertools
import os
import shutil
import socket
import subprocess
import tempfile
from pathlib import Path

import pytest

from tests.system_needs import postgresql_bin, skip_unless

START_ATTEMPTS = 3  # a free port can be taken by another worker between finding it and the server binding it


class PostgresServer:
    """A throwaway PostgreSQL cluster: trust login on 127.0.0.1 only, its socket and data in a temp folder.
    PostgreSQL refuses to run as root, so as root the folder is given to the `postgres` user and every server
    command runs as that user."""

    def __init__(self, bin_folder: Path) -> None:
        self.bin_folder = bin_folder
        self.folder = Path(tempfile.mkdtemp(prefix="pendkit-postgres-"))
        self.as_user = ["runuser", "-u", "postgres", "--"] if os.geteuid() == 0 else []
        if self.as_user:
            shutil.chown(self.folder, "postgres", "postgres")
        self.data = self.folder / "data"
        self.port = 0
        self.databases = itertools.count()

    def _run(self, *command: str) -> None:
        done = subprocess.run([*self.as_user, *command], capture_output=True, text=True, timeout=120)
        if done.returncode != 0:
            log = self.folder / "server.log"
            tail = log.read_text()[-2000:] if log.exists() else ""
            raise RuntimeError(f"{' '.join(command[:2])} failed: {done.stderr.strip() or done.stdout.strip()}\n{tail}")

    def start(self) -> None:
        self._run(str(self.bin_folder / "initdb"), "-D", str(self.data), "-U", "postgres", "--auth=trust",
                  "-E", "UTF8", "--locale=C", "--no-sync")
        for attempt in range(START_ATTEMPTS):
            self.port = _free_port()
            # fsync off: a test cluster thrown away at the end need not survive a power cut
            options = (f"-p {self.port} -k {self.folder} -c listen_addresses=127.0.0.1 -c fsync=off "
                       f"-c max_connections=100")
            try:
                self._run(str(self.bin_folder / "pg_ctl"), "-D", str(self.data), "-l", str(self.folder / "server.log"),
                          "-o", options, "-w", "-t", "60", "start")
                return
            except RuntimeError:
                if attempt == START_ATTEMPTS - 1:
                    raise

    def url(self, database: str) -> str:
        return f"postgresql+psycopg://postgres@127.0.0.1:{self.port}/{database}"

    def _admin(self, statement: str) -> None:
        import psycopg

        with psycopg.connect(host="127.0.0.1", port=self.port, user="postgres", dbname="postgres",
                             autocommit=True) as connection:
            connection.execute(statement)

    def new_database(self) -> str:
        """A fresh empty database; its URL."""
        name = f"queue_{next(self.databases)}"
        self._admin(f"CREATE DATABASE {name}")
        return self.url(name)

    def drop_database(self, url: str) -> None:
        self._admin(f"DROP DATABASE IF EXISTS {url.rsplit('/', 1)[1]} WITH (FORCE)")

    def stop(self) -> None:
        try:
            if self.port:
                self._run(str(self.bin_folder / "pg_ctl"), "-D", str(self.data), "-m", "fast", "-w", "stop")
        finally:
            shutil.rmtree(self.folder, ignore_errors=True)


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture(scope="session")
def postgres_server():
    """A PostgreSQL server for the session (skips, naming the install command, where there is none)."""
    skip_unless("postgresql")
    server = PostgresServer(postgresql_bin())
    try:
        server.start()
        yield server
    finally:
        server.stop()


@pytest.fixture(params=["sqlite", "postgresql"])
def queue_url(request, tmp_path):
    """A fresh queue database: an SQLite file, then a database on the session's PostgreSQL server."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'queue.db'}"
        return
    server = request.getfixturevalue("postgres_server")
    url = server.new_database()
    yield url
    server.drop_database(url)


@pytest.fixture
def store(tmp_path):
    """An SQLite queue with one team, "a" (token "token-a"), for the runner's tests."""
    from pendkit.queue.store import QueueStore

    store = QueueStore(str(tmp_path / "queue.db"))
    store.add_team("a", "token-a")
    yield store
    store.close()
