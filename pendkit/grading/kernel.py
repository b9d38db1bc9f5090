"""The only grading code that runs inside a student's kernel: call one of their functions on inputs the
grader sent, and send back what came out, as data.

`pendkit grade` runs every test in its own process and calls the student's function through `serve_call`
(`serve_socket`, see `pendkit.grading.remote`). Expected values and hidden tests never enter the kernel, and nothing the
kernel sends back is code or a score: a student who replaces this module only changes what their own
function appears to return, which is no better than writing that function.
"""

from __future__ import annotations

import difflib
import socket
import sys
from typing import Any

from pendkit.grading import channel, wire
from pendkit.grading.kit_helpers import kits_helpers_in


def serve_socket(path: str) -> None:
    """Answer the grader's calls over the Unix socket at `path` until it sends the end-of-calls message."""
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
        sock.connect(path)
        while request := channel.receive(sock):
            channel.send(sock, serve_call(request))


def serve_call(request: str) -> str:
    """`request`: {"function": name, "calls": [[args...], ...]} (wire format). Returns (wire format)
    {"found": bool, "close": name or None, "outcomes": [{"result": value, "args_after": [digest per
    argument], "raised": None or {"mro": [class names], "message": str}}, ...]}."""
    spec = wire.loads(request, allow_kit=True)
    name = spec["function"]
    namespace = vars(sys.modules["__main__"])
    fn = namespace.get(name)
    if fn is None or not callable(fn):
        candidates = [key for key, value in namespace.items() if callable(value) and not key.startswith("_")]
        close = difflib.get_close_matches(name, candidates, n=1, cutoff=0.6)
        return wire.dumps({"found": False, "close": close[0] if close else None})
    with kits_helpers_in(namespace, spec.get("kit_helpers")):  # the earlier tasks' functions: the kit's own
        outcomes = [_call(fn, list(args)) for args in spec["calls"]]
    return wire.dumps({"found": True, "close": None, "outcomes": outcomes})


def _call(fn, args: list) -> dict[str, Any]:
    outcome: dict[str, Any] = {"result": None, "raised": None}
    try:
        outcome["result"] = fn(*args)
    except KeyboardInterrupt:
        raise
    except BaseException as error:  # noqa: BLE001 - whatever the student's code raised is their result
        outcome["raised"] = {"mro": [kind.__name__ for kind in type(error).__mro__], "message": str(error)[:500]}
    outcome["args_after"] = [wire.digest(arg) for arg in args]  # the grader compares them with what it sent
    return outcome
