"""The in-notebook check's time limit counts the kernel's computing, not the wall clock: a busy laptop (or a
slow import) does not fail a right answer, an endless loop still stops, and so does code that only waits."""

from __future__ import annotations

import time

import pytest

from pendkit.grading.timeouts import CheckTimeout, call_with_timeout


def test_waiting_within_the_cap_is_not_computing():
    started = time.monotonic()
    assert call_with_timeout(lambda: time.sleep(0.6) or "done", 0.2) == "done"  # a busy machine's delay
    assert time.monotonic() - started >= 0.6


def test_an_endless_loop_stops_at_the_computing_limit():
    def spin():
        while True:
            pass

    with pytest.raises(CheckTimeout, match="took longer than 0.2 s of computing"):
        call_with_timeout(spin, 0.2)


def test_code_that_only_waits_stops_at_the_wall_cap():
    with pytest.raises(CheckTimeout, match="waiting"):
        call_with_timeout(lambda: time.sleep(30), 0.2)  # the cap: 5 s past the limit
