"""The grader's handle on a student's function that lives in another process (their kernel).

`RemoteFunction(session, "decode_frame")` is called like the function itself: the arguments go to the
kernel as data, the function runs there, and its return value (or the exception it raised) comes back as
data, together with the arguments as they are after the call, so a function that changes its inputs is
caught. Every test's code, and every expected value, stays in the grader's process.
"""

from __future__ import annotations

import ast
import builtins
import os
import select
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from jupyter_core.utils import run_sync

from pendkit.grading import channel, wire
from pendkit.grading.core import Failed, NotGradable, Outcome
from pendkit.grading.timeouts import CheckTimeout

INTERRUPT_GRACE_S = 5.0
# A test's time limit is charged in the kernel's own CPU time, so a busy machine costs the student nothing;
# code that waits without computing (a sleep, a blocked read) is stopped at this multiple of the limit.
WALL_BACKSTOP_FACTOR, WALL_BACKSTOP_EXTRA_S = 4.0, 10.0
MAX_REPLY_BYTES = 4 << 20  # a kernel's answer to one batch of calls: thousands of times any lab's (under 1 kB)
MAX_REPLY_VALUES = 100_000  # values in it (each opens one JSON object): bounds the grader's memory
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
    """A running kernel (nbclient's `client`, inside `client.setup_kernel()`) to call functions in.

    With `channel_dir` (a folder both sides can reach) the calls go over a Unix socket there, answered by
    one long execute request in the kernel (`kernel.serve_socket`); without it each batch of calls is an
    execute request of its own (Windows, which has no Unix sockets in Python).

    `cpu_s()` reads the kernel's CPU seconds (its process tree): a test is out of time once its wall limit
    has passed *and* the kernel spent that long computing, or at the wall backstop; without it, at the
    wall limit."""

    client: object
    channel_dir: Path | None = None
    cpu_s: Callable[[], float | None] | None = None
    deadline: float = float("inf")  # monotonic time of the current test's wall limit
    backstop: float = float("inf")  # monotonic time past which it ends whatever its CPU
    limit_s: float = float("inf")  # the current test's time limit, for the message
    _cpu_at_start: float | None = field(default=None, repr=False)
    _connection: socket.socket | None = field(default=None, repr=False)
    _serve_id: str | None = field(default=None, repr=False)

    def start_test(self, limit_s: float) -> None:
        now = time.monotonic()
        self.limit_s, self.deadline = limit_s, now + limit_s
        self.backstop = now + limit_s * WALL_BACKSTOP_FACTOR + WALL_BACKSTOP_EXTRA_S
        self._cpu_at_start = self.cpu_s() if self.cpu_s is not None else None

    def _grace(self, seconds: float) -> None:
        """A plain wall-clock limit (interrupts, the end of the calls)."""
        self.deadline = self.backstop = time.monotonic() + seconds
        self._cpu_at_start = None

    def out_of_time(self) -> bool:
        now = time.monotonic()
        if now < self.deadline:
            return False
        if now >= self.backstop or self._cpu_at_start is None:
            return True
        spent = self.cpu_s()
        return spent is None or spent - self._cpu_at_start >= self.limit_s

    def _timeout(self) -> CheckTimeout:
        return CheckTimeout(f"took longer than {self.limit_s:g} s")

    def call(self, name: str, calls: list[tuple], kit_helpers: dict[str, str] | None = None) -> dict:
        request = wire.dumps({"function": name, "calls": [list(args) for args in calls],
                              "kit_helpers": dict(kit_helpers or {})}, allow_kit=True)
        text = self._over_socket(request) if self.channel_dir is not None else self._over_execute(request)
        if text.count("{") > MAX_REPLY_VALUES:
            raise StudentError("an oversized answer", f"the answer held over {MAX_REPLY_VALUES} values, more than "
                               "the grader reads: return what the task asks for, not more")
        try:
            return wire.loads(text)
        except (ValueError, TypeError, MemoryError, RecursionError, wire.WireError):
            raise StudentError("an unreadable answer", "the kernel's answer was not data the grader understands") \
                from None

    def close(self) -> None:
        """End the kernel's serving request (it is then free for a new cell or a shutdown)."""
        if self._connection is None:
            return
        try:
            channel.send(self._connection, "")
            self._grace(INTERRUPT_GRACE_S)
            self._wait(self.client.kc, self._serve_id)
        except (OSError, CheckTimeout, KernelLost):
            pass  # the kernel is shut down next anyway
        finally:
            self._drop()

    def _over_socket(self, request: str) -> str:
        if self._connection is None:
            self._open()
        try:
            self._connection.settimeout(max(0.001, self.backstop - time.monotonic()))
            channel.send(self._connection, request)
            while not select.select([self._connection], [], [], 0.2)[0]:  # the answer's first byte
                if self.out_of_time():
                    raise TimeoutError
            text = channel.receive(self._connection, self.backstop, MAX_REPLY_BYTES)  # then the whole reply
        except TimeoutError:
            self._abandon_call()
            raise self._timeout() from None
        except channel.TooLarge as error:
            self._abandon_call()
            raise StudentError("an oversized answer", f"the answer was {error.size} bytes, more than the "
                               f"{MAX_REPLY_BYTES} the grader reads: return what the task asks for, not more") from None
        except OSError as error:
            text, problem = None, error
        else:
            problem = None
        if text is None:  # the serving request ended: the kernel died, or the student's code broke the loop
            serve_id = self._serve_id
            self._drop()
            grace = time.monotonic() + INTERRUPT_GRACE_S
            while time.monotonic() < grace:  # a dying kernel may still look alive for a moment
                if not run_sync(self.client.km.is_alive)():
                    raise KernelLost("the function killed the kernel") from None
                if _shell_reply(self.client.kc, serve_id, timeout_s=0.1) is not None:
                    break
            raise StudentError("a broken connection", f"the kernel stopped answering ({problem or 'it hung up'})")
        return text

    def _abandon_call(self) -> None:
        """Stop the kernel's serving request mid-answer; the next call opens a new one."""
        serve_id = self._serve_id
        self._drop()  # the kernel's send fails once the socket is gone, if the interrupt did not stop it
        self._interrupt(self.client.kc, serve_id)

    def _open(self) -> None:
        kc = self.client.kc
        path = Path(self.channel_dir) / "calls.sock"
        path.unlink(missing_ok=True)
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as listener:
            listener.bind(str(path))
            os.chmod(path, 0o777)  # a sandboxed kernel runs as another user
            listener.listen(1)
            code = f"__import__('pendkit.grading.kernel', fromlist=['serve_socket']).serve_socket({str(path)!r})"
            self._serve_id = kc.execute(code, silent=True, store_history=False, stop_on_error=False)
            while True:
                if select.select([listener], [], [], 0.2)[0]:
                    self._connection = listener.accept()[0]
                    break
                reply = _shell_reply(kc, self._serve_id, timeout_s=0.0)
                if reply is not None:
                    content = reply["content"]
                    raise StudentError(str(content.get("ename", "an error")), f"{str(content.get('evalue', ''))[:200]}"
                                       " (the grader could not reach the function in the kernel)")
                if self.out_of_time():
                    self._interrupt(kc, self._serve_id)
                    raise self._timeout()
                if not run_sync(self.client.km.is_alive)():
                    raise KernelLost("the kernel died") from None
        path.unlink(missing_ok=True)

    def _drop(self) -> None:
        if self._connection is not None:
            self._connection.close()
        self._connection, self._serve_id = None, None

    def _over_execute(self, request: str) -> str:
        kc = self.client.kc
        code = ("_pendkit_reply = __import__('pendkit.grading.kernel', fromlist=['serve_call'])"
                f".serve_call({request!r})")
        msg_id = kc.execute(code, silent=True, store_history=False, user_expressions={"reply": "_pendkit_reply"},
                            stop_on_error=False)
        content = self._wait(kc, msg_id)["content"]
        if content.get("status") != "ok":
            raise StudentError(str(content.get("ename", "an error")),
                               f"{str(content.get('evalue', ''))[:200]} (the call failed in the kernel)")
        expression = content.get("user_expressions", {}).get("reply", {})
        try:
            text = expression["data"]["text/plain"]
            if len(text) > 2 * MAX_REPLY_BYTES:  # its repr: about twice the text
                raise ValueError("too large")
            return ast.literal_eval(text)
        except (KeyError, ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
            raise StudentError("an unreadable answer", "the kernel's answer was not data the grader understands") \
                from None

    def _wait(self, kc, msg_id: str) -> dict:
        while True:
            if self.out_of_time():
                self._interrupt(kc, msg_id)
                raise self._timeout()
            reply = _shell_reply(kc, msg_id, timeout_s=0.25)  # returns as soon as the reply is there
            if reply is not None:
                return reply
            if not run_sync(self.client.km.is_alive)():
                raise KernelLost("the function killed the kernel") from None

    def _interrupt(self, kc, msg_id: str) -> None:
        """Stop the running call and wait for its reply, so the next call starts clean."""
        run_sync(self.client.km.interrupt_kernel)()
        grace = time.monotonic() + INTERRUPT_GRACE_S
        while time.monotonic() < grace:
            if _shell_reply(kc, msg_id, timeout_s=0.5) is not None:
                return
        raise KernelLost("the kernel did not stop after an interrupt")


def _shell_reply(kc, msg_id: str, timeout_s: float) -> dict | None:
    """The reply to `msg_id` if it comes within `timeout_s` (others are dropped: nothing else is pending)."""
    end = time.monotonic() + timeout_s
    while True:
        try:
            reply = run_sync(kc.get_shell_msg)(timeout=max(0.0, end - time.monotonic()))
        except Exception as error:  # queue.Empty on a timeout; anything else is a real problem
            if type(error).__name__ != "Empty":
                raise
            return None
        if reply.get("parent_header", {}).get("msg_id") == msg_id:
            return reply


class RemoteFunction:
    """Called like the student's function; runs it in their kernel (see the module docstring)."""

    def __init__(self, session: KernelSession, name: str, kit_helpers: dict[str, str] | None = None) -> None:
        self.session, self.__name__, self.kit_helpers = session, name, kit_helpers

    def __call__(self, *args):
        outcome = self.many([args])[0]
        if outcome.error is not None:
            raise outcome.error
        return outcome.value

    def many(self, calls: list[tuple]) -> list[Outcome]:
        """Every call in one round trip; each outcome is checked for changed inputs."""
        answer = self.session.call(self.__name__, calls, self.kit_helpers)
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
