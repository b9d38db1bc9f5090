"""Feedback names an exception as the student knows it: their own class's name, also when it came back from
their kernel (the grader's StudentError stands in for it there), and a time limit as a time limit."""

from __future__ import annotations

import pytest

from pendkit.grading import core
from pendkit.grading.remote import StudentError
from pendkit.grading.suites import lab01


class BadFrame(Exception):
    """A student's own exception class."""


def in_the_notebook(frame):
    raise BadFrame("no")


def through_the_grader(frame):  # what RemoteFunction raises for the same code run in the student's kernel
    raise StudentError("BadFrame", "no")


@pytest.mark.parametrize("decode_frame", [in_the_notebook, through_the_grader])
def test_a_bad_frame_test_names_the_students_own_exception(decode_frame):
    test = core.TestCase("bad_parity_is_rejected", 1, lambda fn, rng: lab01._rejects(fn, 0x6921))
    result = core.run_test(test, decode_frame)
    assert "decode_frame(0x6921) raised BadFrame; a bad frame should raise ValueError" in result.message, result
    assert "StudentError" not in result.message
