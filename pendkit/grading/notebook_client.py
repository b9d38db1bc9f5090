"""nbclient's notebook client as the grader uses it: a cap on the output it keeps of a student's kernel, and
the kernel's end (client, process and socket files) after every run of the notebook."""

from __future__ import annotations

import logging

from jupyter_core.utils import run_sync
from nbclient import NotebookClient

LOG = logging.getLogger("pendkit.grading")
MAX_KEPT_OUTPUT_BYTES = 16 << 20  # a notebook's printed text and figures the grader holds in memory


def _size(msg: dict) -> int:
    content = msg.get("content", {})
    if msg.get("msg_type") == "stream":
        return len(content.get("text", ""))
    data = content.get("data", {}) or {}
    return sum(len(value) if isinstance(value, str) else len(str(value)) for value in data.values())


class CappedNotebookClient(NotebookClient):
    """Keeps at most `MAX_KEPT_OUTPUT_BYTES` of a notebook's outputs (errors always, their tracebacks
    shortened); what was dropped is counted in `dropped_output_bytes` for the student's feedback."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.kept_output_bytes = 0
        self.dropped_output_bytes = 0

    def output(self, outs, msg, display_id, cell_index):
        if msg.get("msg_type") == "error":
            content = msg.get("content", {})
            content["traceback"] = list(content.get("traceback", []))[-20:]
            return super().output(outs, msg, display_id, cell_index)
        size = _size(msg)
        if self.kept_output_bytes + size > MAX_KEPT_OUTPUT_BYTES:
            self.dropped_output_bytes += size
            return None
        self.kept_output_bytes += size
        return super().output(outs, msg, display_id, cell_index)


def end_kernel(client: NotebookClient, km) -> None:
    """Stop the client's channels first (so it reads nothing more), then the kernel, then remove its
    connection and socket files: the next start never meets this kernel's client or sockets."""
    if client.kc is not None:
        try:
            client.kc.stop_channels()
        except Exception as error:  # noqa: BLE001 - the kernel is killed next anyway
            LOG.warning("could not stop a kernel client: %s", error)
        client.kc = None
    if km is None:
        return
    try:
        if run_sync(km.is_alive)():
            run_sync(km.shutdown_kernel)(now=True)
    except Exception as error:  # noqa: BLE001 - a sandbox's close() or the process guard ends what is left
        LOG.warning("could not stop a kernel: %s", error)
    try:
        run_sync(km.cleanup_resources)()
    except Exception:  # noqa: BLE001 - its files sit in a folder that is removed with the run
        pass


def kernel_alive(client: NotebookClient) -> bool:
    try:
        return bool(run_sync(client.km.is_alive)())
    except Exception:  # noqa: BLE001 - a kernel that cannot even say is not one to go on with
        return False
