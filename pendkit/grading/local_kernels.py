"""Kernels on this machine that talk over Unix sockets in a folder of their own.

Over TCP, jupyter_client picks free ports and the kernel binds them a moment later, so two processes
starting kernels at once (`pendkit grade --jobs`, a test suite's workers) can be handed the same port: the
client then reads another kernel's messages ("Invalid Signature") or none ("kernel died"). A socket path
in a folder no one else uses cannot be taken that way.
"""

from __future__ import annotations

import os
from pathlib import Path


def unix_socket_kernel_manager(folder: str | Path, kernel_name: str = "python3", manager_class=None, **kwargs):
    """A kernel manager (default jupyter_client's AsyncKernelManager) whose sockets are files `folder/kernel-N`,
    the folder made if missing; None where there are no Unix sockets (Windows: the caller's default, TCP)."""
    if os.name != "posix":
        return None
    if manager_class is None:
        from jupyter_client.manager import AsyncKernelManager as manager_class
    Path(folder).mkdir(parents=True, exist_ok=True)
    return manager_class(kernel_name=kernel_name, transport="ipc", ip=str(Path(folder) / "kernel"), **kwargs)
