"""Inside the grading sandbox: set the kernel's resource limits, then become the IPython kernel.

    python -m pendkit.grading.sandbox_launch --cpu-s 1200 --memory-mb 8192 --file-mb 512 --nproc 600 \
        -- -f <connection file>

`--nproc` caps the processes of this user, counted system-wide (0: no cap; root ignores the cap anyway).
"""

from __future__ import annotations

import argparse
import os
import resource
import runpy
import sys


def set_limits(cpu_s: int, memory_mb: int, file_mb: int, nproc: int) -> None:
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_s, cpu_s))
    resource.setrlimit(resource.RLIMIT_AS, (memory_mb << 20, memory_mb << 20))
    resource.setrlimit(resource.RLIMIT_FSIZE, (file_mb << 20, file_mb << 20))
    if nproc > 0:
        resource.setrlimit(resource.RLIMIT_NPROC, (nproc, nproc))


def main() -> None:
    parser = argparse.ArgumentParser()
    for name in ("--cpu-s", "--memory-mb", "--file-mb", "--nproc"):
        parser.add_argument(name, type=int, required=True)
    args, rest = parser.parse_known_args()
    set_limits(args.cpu_s, args.memory_mb, args.file_mb, args.nproc)
    quiet = os.open(os.devnull, os.O_WRONLY)
    os.dup2(quiet, 1)  # the kernel's own banner; the notebook's output goes over the kernel protocol
    sys.argv = ["ipykernel_launcher", *[a for a in rest if a != "--"]]
    runpy.run_module("ipykernel_launcher", run_name="__main__", alter_sys=True)


if __name__ == "__main__":
    main()
