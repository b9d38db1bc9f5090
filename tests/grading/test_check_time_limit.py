"""The in-notebook check's time limit counts the kernel's computing, not the wall clock: a busy laptop (or a
slow import) does not fail a right answer, an endless loop still stops, and so does code that only waits."""

from __future__ import annotations

import time

import pytest

from pendkit.grading import core
from pendkit.grading.suites.lab01 import _rejects
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


def test_a_students_catch_all_does_not_swallow_the_limit():
    def careful_but_endless():
        try:
            while True:
                pass
        except Exception:  # noqa: BLE001 - the student's own catch-all
            return 0.0

    with pytest.raises(CheckTimeout):
        call_with_timeout(careful_but_endless, 0.2)


def test_a_test_that_expects_an_exception_reports_a_timeout_as_a_timeout():
    def endless(frame):
        while True:
            pass

    test = core.TestCase("bad_parity_is_rejected", 1, lambda fn, rng: _rejects(fn, 0x6921), timeout_s=0.2)
    result = core.run_test(test, endless)
    assert result.message.startswith("took longer than 0.2 s of computing: is there an endless loop?"), result
