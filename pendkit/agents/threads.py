"""Torch on one thread per process, the kit's default for its small networks.

On a 2-core laptop with other work running, torch's default (a thread per core) makes every matrix
product wait for a busy core: one R-DQN training episode took 1.71 s with 2 threads against 0.70 s with
one (idle, 0.47 and 0.46 s). The kit sets torch's intra-op threads once per process, when it first builds
a network; `PENDKIT_TORCH_THREADS=N` overrides the default (e.g. on a many-core workstation).
"""

from __future__ import annotations

import os

import torch

from pendkit.errors import ConfigError

THREADS_VARIABLE = "PENDKIT_TORCH_THREADS"
DEFAULT_THREADS = 1
_applied: int | None = None


def kit_thread_count() -> int:
    """The thread count the kit uses: `PENDKIT_TORCH_THREADS` if set, else one."""
    text = os.environ.get(THREADS_VARIABLE, "").strip()
    if not text:
        return DEFAULT_THREADS
    try:
        count = int(text)
    except ValueError:
        count = 0
    if count < 1:
        raise ConfigError(f"{THREADS_VARIABLE}={text!r}: expected a whole number of threads >= 1 "
                          f"(unset it for the kit's default of {DEFAULT_THREADS})")
    return count


def use_kit_threads() -> int:
    """Set torch's threads to the kit's count, once per process (later calls leave a user's own
    `torch.set_num_threads` alone); returns the count in use."""
    global _applied
    if _applied is None:
        _applied = kit_thread_count()
        torch.set_num_threads(_applied)
    return torch.get_num_threads()
