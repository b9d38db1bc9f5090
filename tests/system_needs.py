"""What parts of the suite need from the system beyond pip, and the command that installs each (Debian or
Ubuntu; `.ci/run` installs them all). Without one its tests skip, naming the command; the run's summary
lists what was skipped and why. `PENDKIT_TESTS_WITHOUT=mosquitto,bubblewrap,postgresql` runs the suite as a machine
without them would (a newcomer's first run)."""

from __future__ import annotations

import importlib.util
import os
import shutil
from pathlib import Path

import pytest

from pendkit.grading.sandbox import isolation_problem
from pendkit.link.broker import mosquitto_binary

INSTALL = {
    "mosquitto": "sudo apt-get install mosquitto",
    "openssl": "sudo apt-get install openssl",
    "chromium": "sudo apt-get install chromium && pip install playwright",
    "bubblewrap": "sudo apt-get install bubblewrap",
    "postgresql": "sudo apt-get install postgresql && pip install -e \".[postgres]\"",
}


def postgresql_bin() -> Path | None:
    """The folder with Debian's `initdb` and `pg_ctl` (the newest major version), else the one on PATH."""
    for folder in sorted(Path("/usr/lib/postgresql").glob("*/bin"), key=lambda f: _major(f.parent.name),
                         reverse=True):
        if (folder / "initdb").exists() and (folder / "pg_ctl").exists():
            return folder
    initdb = shutil.which("initdb")
    return Path(initdb).parent if initdb and shutil.which("pg_ctl") else None


def _major(version: str) -> int:
    return int(version) if version.isdigit() else -1


HAVE = {
    "mosquitto": mosquitto_binary() is not None,
    "openssl": shutil.which("openssl") is not None,
    "chromium": (shutil.which("chromium") or shutil.which("chromium-browser")) is not None,
    # the server for tests/queue (they start their own) and the driver the queue's store talks to it with
    "postgresql": postgresql_bin() is not None and importlib.util.find_spec("psycopg") is not None,
}


def why_missing(need: str) -> str | None:
    """None when `need` is here; else the reason a test skips, with the command that installs it."""
    if need in os.environ.get("PENDKIT_TESTS_WITHOUT", "").split(","):
        return f"needs {need}: {INSTALL[need]}"
    if need == "bubblewrap":
        problem = isolation_problem()
        return None if problem is None else f"needs the grader's sandbox: {problem} ({INSTALL[need]})"
    return None if HAVE[need] else f"needs {need}: {INSTALL[need]}"


def class_isolation() -> bool | None:
    """What a test grading a class passes as `isolate`: the sandbox where there is one, else an explicit
    False (a class without a sandbox is refused unless asked for, as `--no-sandbox` does)."""
    return None if isolation_problem() is None else False


def no_sandbox_args() -> list[str]:
    """The same for `pendkit grade`'s command line."""
    return [] if isolation_problem() is None else ["--no-sandbox"]


def needs(*wanted: str) -> pytest.MarkDecorator:
    """`@needs("mosquitto")`: skip, saying how to install it, where it is missing."""
    reasons = [r for r in map(why_missing, wanted) if r]
    return pytest.mark.skipif(bool(reasons), reason="; ".join(reasons) or "all here")


def skip_unless(*wanted: str) -> None:
    """The same inside a fixture or a test."""
    reasons = [r for r in map(why_missing, wanted) if r]
    if reasons:
        pytest.skip("; ".join(reasons))
