"""The README's test command timed: wall seconds, the CPU seconds of every process it ran, and how busy that
kept the cores (its own processes; the whole machine's from /proc/stat). Goal: <= 6 minutes on 2 cores in an
environment made by the README's first command.

    python benchmarks/bench_test_suite.py [--workers auto 3 4] [-- extra pytest arguments]

Run it on an idle machine: a training beside it takes the cores the suite's workers share. The CPU count
covers the suite's children once they have ended (workers, notebook kernels, graders' sandboxes).
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def children_cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def machine_busy_s() -> tuple[float, float] | None:
    """(busy, all) CPU seconds of the whole machine since boot, from /proc/stat (Linux); None elsewhere."""
    try:
        fields = [float(x) for x in Path("/proc/stat").read_text().split("\n")[0].split()[1:]]
    except OSError:
        return None
    ticks = os.sysconf("SC_CLK_TCK")
    idle = fields[3] + fields[4]  # idle and iowait
    return (sum(fields) - idle) / ticks, sum(fields) / ticks


def share(before: tuple[float, float] | None, after: tuple[float, float] | None) -> str:
    if before is None or after is None:
        return "n/a"
    return f"{100 * (after[0] - before[0]) / (after[1] - before[1]):.0f}%"


def run_suite(workers: str, extra: list[str]) -> dict[str, str]:
    """One run of `python -m pytest` (with `-n workers` unless 'auto'); its figures as printable strings."""
    command = [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *extra]
    if workers != "auto":
        command += ["-n", workers]
    cpu_before, machine_before, started = children_cpu_s(), machine_busy_s(), time.perf_counter()
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    wall_s, cpu_s = time.perf_counter() - started, children_cpu_s() - cpu_before
    machine_after = machine_busy_s()
    summary = re.findall(r"(\d+ (?:passed|failed).*?) in [\d.]+s", done.stdout)
    cores = os.cpu_count() or 1
    return {"workers": workers, "wall_s": f"{wall_s:.0f}", "cpu_s": f"{cpu_s:.0f}",
            "busy": f"{100 * cpu_s / (wall_s * cores):.0f}%", "cores": str(cores),
            "machine_busy": share(machine_before, machine_after),
            "result": (summary[-1] if summary else f"exit {done.returncode}").replace(" ", "_"),
            "failures": re.findall(r"^(?:FAILED|ERROR) .*$", done.stdout, flags=re.MULTILINE)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", nargs="+", default=["auto"], help="xdist workers a run ('auto': the suite's)")
    args, extra = parser.parse_known_args()
    extra = [a for a in extra if a != "--"]
    for workers in args.workers:
        row = run_suite(workers, extra)
        failures = row.pop("failures")
        print(" ".join(f"{key}={value}" for key, value in row.items()), flush=True)
        for line in failures:  # a slower run is no figure if something failed: say what
            print(f"  {line}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
