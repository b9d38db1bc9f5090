"""Run a student's code with a time limit, without needing a separate process (Windows has no fork)."""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable
from typing import Any


class CheckTimeout(BaseException):
    """A check ran past its time limit. Not an Exception: a test's or the student's own `except Exception`
    must not take the timeout for the function's answer (e.g. "raised CheckTimeout; it should raise ValueError")."""


def call_with_timeout(func: Callable[[], Any], timeout_s: float) -> Any:
    """Call `func()`; raise `CheckTimeout` after `timeout_s` seconds.

    On Unix in the main thread (a Jupyter kernel) an interval timer interrupts the code itself. Elsewhere
    the call runs in a daemon thread that is abandoned on timeout (it cannot be killed), which is why
    `pendkit grade` also bounds every cell with the kernel's own timeout.
    """
    if timeout_s <= 0:
        return func()
    if hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread():
        return _with_alarm(func, timeout_s)
    return _with_thread(func, timeout_s)


WAIT_FACTOR = 6.0  # a check may also wait (a rig, a file) up to this many times its computing limit


def _with_alarm(func: Callable[[], Any], timeout_s: float) -> Any:
    """The limit counts the process's CPU time, so a laptop busy with other work does not fail a right answer
    (an import or a slow machine costs wall time, not this process's computing); a wall-clock cap of
    `WAIT_FACTOR` times as long stops code that waits forever without computing."""
    wait_s = max(timeout_s * WAIT_FACTOR, timeout_s + 5.0)

    def on_cpu(signum, frame):
        raise CheckTimeout(f"took longer than {timeout_s:g} s of computing")

    def on_wall(signum, frame):
        raise CheckTimeout(f"took longer than {wait_s:g} s waiting")

    previous = signal.signal(signal.SIGPROF, on_cpu), signal.signal(signal.SIGALRM, on_wall)
    signal.setitimer(signal.ITIMER_PROF, timeout_s)
    signal.setitimer(signal.ITIMER_REAL, wait_s)
    try:
        return func()
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGPROF, previous[0])
        signal.signal(signal.SIGALRM, previous[1])


def _with_thread(func: Callable[[], Any], timeout_s: float) -> Any:
    outcome: dict[str, Any] = {}

    def target() -> None:
        try:
            outcome["value"] = func()
        except BaseException as error:  # handed back to the caller below
            outcome["error"] = error

    worker = threading.Thread(target=target, daemon=True, name="pendkit-check")
    worker.start()
    worker.join(timeout_s)
    if worker.is_alive():
        raise CheckTimeout(f"took longer than {timeout_s:g} s (still running in the background)")
    if "error" in outcome:
        raise outcome["error"]
    return outcome.get("value")
