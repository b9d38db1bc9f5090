"""What `pendkit adapt` shows while it works: a bar per stage with the time it expects to take, on the terminal
(stderr) or in a notebook (tqdm's auto bar); nothing when tqdm is missing."""

from __future__ import annotations

import math
import time
from contextlib import contextmanager


class _Bar:
    """A tqdm bar (or nothing): `advance(n)` by counted work, `tick()` to the seconds elapsed (a time bar)."""

    def __init__(self, bar, deadline: float | None = None) -> None:
        self.bar, self.deadline, self.started = bar, deadline, time.time()

    def advance(self, n: int = 1, note: str | None = None) -> None:
        if self.bar is not None:
            self.bar.update(n)
            if note:
                self.bar.set_postfix_str(note, refresh=False)

    def tick(self, note: str | None = None) -> None:
        if self.bar is None:
            return
        elapsed = min(int(time.time() - self.started), int(self.bar.total or 0))
        if elapsed > self.bar.n:
            self.bar.update(elapsed - self.bar.n)
        if note:
            self.bar.set_postfix_str(note)


def _tqdm(**kwargs):
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    return tqdm(leave=False, mininterval=0.5, disable=None, **kwargs)  # None: no bar when not a terminal


@contextmanager
def work_bar(desc: str, total: int, unit: str):
    """A bar over `total` units of work (its estimate of the time left from the rate so far)."""
    bar = _Bar(_tqdm(desc=desc, total=total, unit=unit))
    try:
        yield bar
    finally:
        if bar.bar is not None:
            bar.bar.close()


@contextmanager
def seconds_bar(desc: str, deadline: float):
    """A bar over the seconds until `deadline` (a `time.time()`; none shown when it is unbounded)."""
    left = deadline - time.time()
    bar = _Bar(_tqdm(desc=desc, total=int(math.ceil(left)), unit="s") if math.isfinite(left) else None, deadline)
    try:
        yield bar
    finally:
        if bar.bar is not None:
            bar.bar.close()
