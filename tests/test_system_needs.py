"""A machine without mosquitto, openssl, Chromium or bubblewrap skips what needs them, with the command that
installs each, and the run's summary says so."""

import subprocess
import sys
from pathlib import Path

from tests.system_needs import INSTALL, why_missing

ROOT = Path(__file__).resolve().parents[1]


def test_each_missing_need_names_the_command_that_installs_it(monkeypatch):
    monkeypatch.setenv("PENDKIT_TESTS_WITHOUT", ",".join(INSTALL))
    for need, command in INSTALL.items():
        assert command in why_missing(need) and command.startswith("sudo apt-get install")


def test_a_run_without_mosquitto_skips_its_tests_and_the_summary_says_why():
    run = subprocess.run([sys.executable, "-m", "pytest", "-n", "0", "-q", "-p", "no:cacheprovider",
                          "tests/link/test_classroom_teams.py", "-k", "takeover or tls"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300,
                         env={**__import__("os").environ, "PENDKIT_TESTS_WITHOUT": "mosquitto"})
    assert run.returncode == 0, run.stdout[-2000:]
    assert "skipped, and why" in run.stdout and "needs mosquitto: sudo apt-get install mosquitto" in run.stdout, \
        run.stdout[-2000:]
