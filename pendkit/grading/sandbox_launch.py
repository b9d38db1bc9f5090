"""Inside the grading sandbox: become the kernel's own user (when started as root), set the kernel's
resource limits, then become the IPython kernel.

    python -m pendkit.grading.sandbox_launch --cpu-s 1200 --memory-mb 8192 --file-mb 512 --nproc 600 \
        --uid 61234 -- -f <connection file>

`--nproc` caps the processes (and threads) of this user, counted system-wide (0: no cap). `--uid -1`:
stay who we are (a normal user's grader: the user namespace already took every privilege away).
"""

from __future__ import annotations

import argparse
import os
import resource
import runpy
import shutil
import sys


def set_limits(cpu_s: int, memory_mb: int, file_mb: int, nproc: int) -> None:
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_s, cpu_s))
    resource.setrlimit(resource.RLIMIT_AS, (memory_mb << 20, memory_mb << 20))
    resource.setrlimit(resource.RLIMIT_FSIZE, (file_mb << 20, file_mb << 20))
    if nproc > 0:
        resource.setrlimit(resource.RLIMIT_NPROC, (nproc, nproc))


def become(uid: int, connection_file: str) -> str:
    """Drop root for `uid` (no groups, no capabilities left); returns the connection file's copy that
    this user can read (the grader wrote the original readable by root only)."""
    copy = os.path.join(os.environ["HOME"], "connection.json")
    shutil.copyfile(connection_file, copy)
    os.chown(copy, uid, uid)
    os.setgroups([])
    os.setgid(uid)
    os.setuid(uid)  # every capability goes with root
    if os.getuid() != uid or os.geteuid() != uid:
        raise SystemExit("could not drop root")
    return copy


def main() -> None:
    parser = argparse.ArgumentParser()
    for name in ("--cpu-s", "--memory-mb", "--file-mb", "--nproc", "--uid"):
        parser.add_argument(name, type=int, required=True)
    args, rest = parser.parse_known_args()
    rest = [a for a in rest if a != "--"]
    if args.uid >= 0:
        at = rest.index("-f") + 1
        rest[at] = become(args.uid, rest[at])
    set_limits(args.cpu_s, args.memory_mb, args.file_mb, args.nproc)
    quiet = os.open(os.devnull, os.O_WRONLY)
    os.dup2(quiet, 1)  # the kernel's own banner; the notebook's output goes over the kernel protocol
    sys.argv = ["ipykernel_launcher", *rest]
    runpy.run_module("ipykernel_launcher", run_name="__main__", alter_sys=True)


if __name__ == "__main__":
    main()
