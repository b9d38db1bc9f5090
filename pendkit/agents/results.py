"""Measured results that ship with the kit, read by the labs: written by the benchmarks, never typed in.

`delay_sweep()` reads `pendkit/data/delay_sweep.json`, written by
`pendkit sweep report DIR --delay-sweep-json pendkit/data/delay_sweep.json` after a sweep of
`benchmarks/sweeps/lab08-delay.yaml` (docs/sweeps.md; `bench_learning.py --sweep-delay-steps ... --json`
writes the same format).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

DATA = Path(__file__).resolve().parent.parent / "data"


@dataclass(frozen=True)
class DelaySweep:
    """Success rates (solved seeds / seeds) per learner at each delay, and how they were measured."""

    delays_ms: list[float]
    success_rate: dict[str, list[float]]
    seeds: int
    command: str
    solved_rule: str
    max_episodes: int  # a run's budget: a seed not solved within it counts as not solved


def delay_sweep(path: str | Path | None = None) -> DelaySweep:
    record = json.loads(Path(path or DATA / "delay_sweep.json").read_text())
    delays = list(record["delays_ms"])
    rates: dict[str, list[float]] = {}
    seeds = 0
    for run in record["runs"]:
        solved = [episodes is not None for episodes in run["episodes"]]
        rates.setdefault(run["algo"], []).append(sum(solved) / len(solved))
        seeds = len(solved)
    for algo, values in rates.items():
        if len(values) != len(delays):
            raise ValueError(f"{algo} has {len(values)} sweep points for {len(delays)} delays in the file")
    return DelaySweep(delays, rates, seeds, record["command"], record["solved_rule"], int(record["max_episodes"]))
