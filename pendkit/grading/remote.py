"""The grader's handle on a student's function that lives in another process (their kernel).

`RemoteFunction(session, "decode_frame")` is called like the function itself: the arguments go to the
kernel as data, the function runs there, and its return value (or the exception it raised) comes back as
data, together with the arguments as they are after the call, so a function that changes its inputs is
caught. Every test's code, and every expected value, stays in the grader's process.
"""

from __future__ import annotations

import ast
import builtins
import time
from dataclasses import dataclass

from pendkit.grading import wire
from pendkit.grading.core import Failed, NotGradable, Outcome
from pendkit.grading.timeouts import CheckTimeout

INTERRUPT_GRACE_S = 5.0
# What a student's exception may come back as; anything else is a StudentError.
RAISABLE = ("ValueError", "TypeError", "NotImplementedError", "ZeroDivisionError", "IndexError", "KeyError",
            "AttributeError", "ArithmeticError", "OverflowError", "FloatingPointError", "RuntimeError",
            "RecursionError", "LookupError", "NameError", "UnboundLocalError", "AssertionError", "MemoryError")


class StudentError(Exception):
    """An exception of the student's own (or an unusual built-in) raised by their function."""

    def __init__(self, shown_as: str, message: str) -> None:
        super().__init__(message)
        self.shown_as = shown_as


class KernelLost(BaseException):  # not an Exception: no test may catch it, the runner must
    """The kernel did not come back from an interrupt, or died: the runner starts a new one."""


class MissingFunction(NotGradable):
    """The notebook defines no function of that name."""


@dataclass
class KernelSession:
    """A running kernel (nbclient's `client`, inside `client.setup_kernel()`) to call functions in."""

    client: object
    deadline: float = float("inf")  # monotonic time by which the current test must be done
    limit_s: float = float("inf")  # the current test's time limit, for the message

    def start_test(self, limit_s: float) -> None:
        self.limit_s, self.deadline = limit_s, time.monotonic() + limit_s

    def call(self, name: str, calls: list[tuple]) -> dict:
        from jupyter_core.utils import run_sync

        kc = self.client.kc
        request = wire.dumps({"function": name, "calls": [list(args) for args in calls]}, allow_kit=True)
        code = ("_pendkit_reply = __import__('pendkit.grading.kernel', fromlist=['serve_call'])"
                f".serve_call({request!r})")
        msg_id = kc.execute(code, silent=True, store_history=False, user_expressions={"reply": "_pendkit_reply"},
                            stop_on_error=False)
        reply = self._wait(run_sync, kc, msg_id)
        content = reply["content"]
        if content.get("status") != "ok":
            raise StudentError(str(content.get("ename", "an error")),
                               f"{str(content.get('evalue', ''))[:200]} (the call failed in the kernel)")
        expression = content.get("user_expressions", {}).get("reply", {})
        try:
            text = ast.literal_eval(expression["data"]["text/plain"])
            return wire.loads(text)
        except (KeyError, ValueError, SyntaxError, TypeError, MemoryError, RecursionError, wire.WireError):
            raise StudentError("an unreadable answer", "the kernel's answer was not data the grader understands") \
                from None

    def _wait(self, run_sync, kc, msg_id: str) -> dict:
        while True:
            remaining = self.deadline - time.monotonic()
            if remaining <= 0:
                self._interrupt(run_sync, kc, msg_id)
                raise CheckTimeout(f"took longer than {self.limit_s:g} s")
            try:
                reply = run_sync(kc.get_shell_msg)(timeout=min(remaining, 1.0))
            except Exception as error:  # queue.Empty on a timeout; anything else: check the kernel
                if type(error).__name__ != "Empty":
                    raise
                if not run_sync(self.client.km.is_alive)():
                    raise KernelLost("the function killed the kernel") from None
                continue
            if reply.get("parent_header", {}).get("msg_id") == msg_id:
                return reply

    def _interrupt(self, run_sync, kc, msg_id: str) -> None:
        """Stop the running call and wait for its reply, so the next call starts clean."""
        run_sync(self.client.km.interrupt_kernel)()
        grace = time.monotonic() + INTERRUPT_GRACE_S
        while time.monotonic() < grace:
            try:
                reply = run_sync(kc.get_shell_msg)(timeout=0.5)
            except Exception:  # noqa: BLE001 - nothing yet
                continue
            if reply.get("parent_header", {}).get("msg_id") == msg_id:
                return
        raise KernelLost("the kernel did not stop after an interrupt")


class RemoteFunction:
    """Called like the student's function; runs it in their kernel (see the module docstring)."""

    def __init__(self, session: KernelSession, name: str) -> None:
        self.session, self.__name__ = session, name

    def __call__(self, *args):
        outcome = self.many([args])[0]
        if outcome.error is not None:
            raise outcome.error
        return outcome.value

    def many(self, calls: list[tuple]) -> list[Outcome]:
        """Every call in one round trip; each outcome is checked for changed inputs."""
        answer = self.session.call(self.__name__, calls)
        if not answer.get("found"):
            close = answer.get("close")
            hint = f" (found `{close}`: keep the name `{self.__name__}`)" if close else ""
            raise MissingFunction(f"function `{self.__name__}` not found: did you rename it or delete its cell?{hint}")
        results = []
        for args, outcome in zip(calls, answer.get("outcomes", [])):
            raised = outcome.get("raised")
            if raised is not None:
                error = _as_exception(raised)
                if isinstance(error, NotImplementedError):
                    raise error
                results.append(Outcome(error=error))
                continue
            sent, after = [wire.digest(arg) for arg in args], outcome.get("args_after", [])
            if after != sent:
                changed = [f"argument {k + 1}" for k, (old, new) in enumerate(zip(sent, after)) if old != new]
                plural = "s" if len(changed) > 1 else ""
                raise Failed(f"{self.__name__} changed its input{plural} ({', '.join(changed) or 'its arguments'}): "
                             "a function should leave what it is given as it was (work on a copy, e.g. "
                             "np.array(x, dtype=float), and write x = x - y, not x -= y)")
            results.append(Outcome(outcome.get("result")))
        if len(results) != len(calls):
            raise StudentError("an incomplete answer", "the kernel answered fewer calls than were made")
        return results


def _as_exception(raised: dict) -> BaseException:
    mro, message = [str(n) for n in raised.get("mro", [])], str(raised.get("message", ""))[:500]
    for name in mro:
        if name in RAISABLE:
            return getattr(builtins, name)(message)
    return StudentError(mro[0][:60] if mro else "an exception", message)
