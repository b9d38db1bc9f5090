"""The first line every benchmark and study prints, which a results table carries under its command
(docs/results/, held there by tests/test_docs.py): the commit measured, the date and the machine.

    commit=1848c33 date=2026-11-29 machine=x86_64, 2 cores, Linux, Python 3.11.7, load 1.9
"""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def commit() -> str:
    """The short hash of HEAD, "+changes" when the library or benchmarks differ from it; "unknown" outside git."""
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout.strip()

    try:
        head = git("rev-parse", "--short=7", "HEAD")
        changed = git("status", "--porcelain", "--", "pendkit", "benchmarks", "firmware")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+changes" if changed else "")


def header() -> str:
    load = f", load {os.getloadavg()[0]:.1f}" if hasattr(os, "getloadavg") else ""
    machine = (f"{platform.machine()}, {os.cpu_count()} cores, {platform.system()}, "
               f"Python {platform.python_version()}{load}")
    return f"commit={commit()} date={datetime.date.today().isoformat()} machine={machine}"


def print_header() -> None:
    print(header(), flush=True)


if __name__ == "__main__":
    print_header()
