"""The matching cost of many candidate rigs at once, over the laptop's cores.

Identification spends nearly all its time replaying the recordings on candidate twins, and the candidates of
one generation of differential evolution are independent: each process of the pool holds the recordings once
(sent when it starts, not with every candidate) and replays the candidates it is handed. One core: the same
costs in this process, in order, so a result never depends on how many cores ran it.
"""

from __future__ import annotations

import math
import os
import sys
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import get_context

import numpy as np

from pendkit.rig import RigParams

# Linux forks (the workers replay with MuJoCo and numpy alone, none of the threads a parent may hold); macOS
# and Windows can only spawn, which imports the caller's script again: a script there needs Python's
# `if __name__ == "__main__":` guard, as for any process pool (a notebook or `pendkit adapt` does not)
START_METHOD = "fork" if sys.platform.startswith("linux") else "spawn"
# what a worker replays: set once by `_start_worker` (each worker process has its own copy)
_WORKER: dict = {}

Candidate = Callable[[np.ndarray], tuple[RigParams, float]]


def _start_worker(cost, candidate: Candidate, recordings) -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    _WORKER.update(cost=cost, candidate=candidate, recordings=recordings)


def guarded_cost(cost: Callable[[RigParams, float, list], float], params: RigParams, last: float,
                 recordings: list) -> float:
    """`cost`, or 4.0 (as bad as can be) for a candidate the twin cannot take (an impossible servo) or a value
    that is not finite: what every search over candidate rigs compares."""
    try:
        value = float(cost(params, last, recordings))
    except Exception:
        return 4.0
    return value if math.isfinite(value) else 4.0


def _cost_of(x: np.ndarray) -> float:
    return guarded_cost(_WORKER["cost"], *_WORKER["candidate"](x), _WORKER["recordings"])


def usable_cores(requested: int | None = None) -> int:
    """`requested` processes, or one per core this process may use (at least one)."""
    if requested is not None:
        return max(1, int(requested))
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS and Windows have no affinity call
        return max(1, os.cpu_count() or 1)


class CostPool:
    """`costs(xs)`: the guarded matching cost of each row of `xs` (points of a search box that `candidate`
    turns into (params, latency or PWM phase)), over `workers` processes. Use as a context manager."""

    def __init__(self, cost, candidate: Candidate, recordings: Sequence, workers: int | None = None) -> None:
        self.cost, self.candidate, self.recordings = cost, candidate, list(recordings)
        self.workers = usable_cores(workers)
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> CostPool:
        if self.workers > 1:
            self._pool = ProcessPoolExecutor(self.workers, mp_context=get_context(START_METHOD),
                                             initializer=_start_worker,
                                             initargs=(self.cost, self.candidate, self.recordings))
        return self

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._pool = None

    def costs(self, xs: np.ndarray) -> list[float]:
        rows = [np.asarray(x, dtype=float) for x in np.atleast_2d(xs)]
        if self._pool is None:
            return [guarded_cost(self.cost, *self.candidate(x), self.recordings) for x in rows]
        chunk = max(1, len(rows) // (4 * self.workers))
        try:
            return list(self._pool.map(_cost_of, rows, chunksize=chunk))
        except BrokenProcessPool:  # a worker that could not start (or died): the rest costed here, in order
            warnings.warn("identification's worker processes stopped; replaying on one core from here",
                          RuntimeWarning, stacklevel=2)
            self._pool.shutdown(cancel_futures=True)
            self._pool = None
            return self.costs(xs)
