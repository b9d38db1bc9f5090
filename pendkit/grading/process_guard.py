"""Every process a submission started, found and ended, where no sandbox holds its kernel.

Without bubblewrap a student's kernel runs as the grader's user: a cell can start a daemon in a session of
its own that outlives the kernel, kills the kernels graded after it, or edits grades.csv once `pendkit grade`
has exited. Around each notebook the grader therefore
- becomes a child subreaper (Linux `prctl`): whatever the kernel's descendants orphan comes back to the grader
  as its child, however many times it forked or called `setsid`;
- marks the kernel's environment with a token (`RUN_VARIABLE`) that its descendants inherit;
- and when the notebook is done, kills every new descendant, every process in the kernel's session, and
  every process of this user carrying the token, in rounds until none is left.
On macOS and Windows there is no subreaper: the session and the token find what they can, which is why
`pendkit grade` grades a class without a sandbox only when told (`--no-sandbox`, docs/labs-and-grading.md).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import os
import secrets
import signal
import sys

import psutil

LOG = logging.getLogger("pendkit.grading")
RUN_VARIABLE = "PENDKIT_GRADING_RUN"
PR_SET_CHILD_SUBREAPER, PR_GET_CHILD_SUBREAPER = 36, 37
MAX_ROUNDS = 50  # a fork loop makes new processes while the last ones die: each round stops what is there


def new_run_token() -> str:
    """A token for one `pendkit grade` run; each notebook's kernel gets `token:<n>`."""
    return secrets.token_hex(8)


def _libc():
    if not sys.platform.startswith("linux"):
        return None
    try:
        return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    except OSError:
        return None


def _set_subreaper(on: bool) -> bool | None:
    """Make this process a child subreaper (or not); returns what it was, None where Linux has no prctl."""
    libc = _libc()
    if libc is None:
        return None
    was = ctypes.c_int(0)
    if libc.prctl(PR_GET_CHILD_SUBREAPER, ctypes.byref(was), 0, 0, 0) != 0:
        return None
    libc.prctl(PR_SET_CHILD_SUBREAPER, int(on), 0, 0, 0)
    return bool(was.value)


def _identity(process: psutil.Process) -> tuple[int, float] | None:
    try:
        return process.pid, process.create_time()
    except psutil.Error:
        return None


class ProcessGuard:
    """`with ProcessGuard(token) as guard:` around one notebook's kernels; `guard.watch(pid)` for each kernel
    started; on leaving, everything they started is killed (`ended` counts it)."""

    def __init__(self, token: str) -> None:
        self.token = token
        self.kernel_sessions: set[int] = set()
        self.ended = 0
        self._before: set[tuple[int, float]] = set()
        self._was_subreaper: bool | None = None

    def environment(self) -> dict[str, str]:
        return {RUN_VARIABLE: self.token}

    def watch(self, kernel_pid: int | None) -> None:
        """A kernel just started: its session is searched at the end (it leads one of its own)."""
        if kernel_pid is None:
            return
        try:
            if os.getsid(kernel_pid) == kernel_pid:  # never the grader's own session
                self.kernel_sessions.add(kernel_pid)
        except (OSError, AttributeError):
            pass

    def __enter__(self) -> ProcessGuard:
        self._before = {i for p in psutil.Process().children(recursive=True) if (i := _identity(p))}
        self._was_subreaper = _set_subreaper(True)
        return self

    def __exit__(self, *exc) -> None:
        try:
            self.ended += end_processes(self._leftovers)
        finally:
            if self._was_subreaper is False:
                _set_subreaper(False)

    def _leftovers(self) -> list[psutil.Process]:
        found = {p.pid: p for p in psutil.Process().children(recursive=True) if _identity(p) not in self._before}
        for process in carrying(self.token, exact=True):
            found.setdefault(process.pid, process)
        for process in _same_user():
            try:
                if os.getsid(process.pid) in self.kernel_sessions and process.pid != os.getpid():
                    found.setdefault(process.pid, process)
            except OSError:
                continue
        return list(found.values())


def _same_user():
    uid = os.getuid() if hasattr(os, "getuid") else None
    for process in psutil.process_iter(["uids"]):
        uids = process.info.get("uids")
        if uid is None or uid == 0 or (uids is not None and uids.real == uid):
            yield process


def carrying(token: str, exact: bool) -> list[psutil.Process]:
    """Processes of this user whose environment holds the run token (`exact`: this notebook's; else any
    notebook of the run, `token:*`)."""
    found = []
    for process in _same_user():
        if process.pid == os.getpid():
            continue
        try:
            value = process.environ().get(RUN_VARIABLE)
        except (psutil.Error, OSError):
            continue
        if value is not None and (value == token if exact else value.startswith(token + ":")):
            found.append(process)
    return found


def end_processes(find, settle_s: float = 1.0) -> int:
    """SIGKILL what `find()` returns, in rounds, until it returns nothing; reap our own children. What is
    already ending (a kernel that was just shut down) gets `settle_s` to go by itself and is not counted.
    Returns how many were killed."""
    ended = 0
    for round_number in range(MAX_ROUNDS):
        processes = [p for p in find() if p.pid != os.getpid()]
        if processes and round_number == 0:
            processes = psutil.wait_procs(processes, timeout=settle_s)[1]
        if not processes:
            return ended
        for process in processes:
            try:
                process.send_signal(signal.SIGKILL if hasattr(signal, "SIGKILL") else signal.SIGTERM)
                ended += 1
            except psutil.Error:
                continue
        psutil.wait_procs(processes, timeout=1.0)  # reaps those that are our children
    LOG.warning("processes a submission started were still appearing after %d rounds of kills", MAX_ROUNDS)
    return ended


def kernel_pid(km) -> int | None:
    """The process jupyter_client started for a kernel (bwrap's, for a sandboxed one)."""
    process = getattr(getattr(km, "provisioner", None), "process", None)
    return getattr(process, "pid", None)


def tree_cpu_s(pid: int | None) -> float | None:
    """CPU seconds (user + system) of `pid` and every process below it, the ones it waited for included;
    None when it cannot be read."""
    if pid is None:
        return None
    try:
        root = psutil.Process(pid)
        total = 0.0
        for process in [root, *root.children(recursive=True)]:
            try:
                times = process.cpu_times()
            except psutil.Error:
                continue
            total += times.user + times.system + getattr(times, "children_user", 0.0) + \
                getattr(times, "children_system", 0.0)
        return total
    except psutil.Error:
        return None
