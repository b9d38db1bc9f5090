"""What the recordings leave uncertain, and a twin drawn from it every episode.

An identification is one point, but the recordings rarely pin every field: a stiff servo loop and a soft one
can move the pendulum almost alike in a few jumps. `fit_spread` walks each fitted field away from the fit, one
at a time and in both directions, as far as the twin still matches the recordings within `tolerance` (the
matching cost at most (1 + tolerance) times the fit's: 1.0 means an RMS angle error at most sqrt(2) times
the fit's). `AroundTheFit` then draws a rig from those intervals before every episode (log-uniformly; the
network from the kit's training ranges, since a few recordings say little of jitter or loss), so the policy
`pendkit adapt` trains on the twin is made for every rig the recordings allow, not only the closest.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable

import gymnasium as gym
import numpy as np

from pendkit.adapt.excitation import Recording
from pendkit.adapt.identify import FITTED, Identification, guarded_cost, matching_cost, on_device_clock
from pendkit.adapt.replay import replay_cost
from pendkit.network import LatencyModel, NetworkImpairment
from pendkit.rig import RigParams
from pendkit.sim.fidelity import resolve_fidelity
from pendkit.sim.randomize import TRAINING_RANGES

Interval = tuple[float, float]
# how far each walk looks: log-scale steps for the rig's fields (x1.05 .. x2.7), ms for a fitted latency
LOG_STEPS = (0.05, 0.1, 0.2, 0.35, 0.6, 1.0)
LATENCY_STEPS_MS = (1.0, 2.0, 4.0, 8.0, 16.0)
DEFAULT_TOLERANCE = 1.0
MIN_LOG_HALF_WIDTH = 0.03  # every interval at least x/÷ 1.03 about the fit: a policy never sees one rig only
RIG_FIELDS = tuple(name for name in FITTED if name != "latency_ms")


def with_field(params: RigParams, name: str, value: float) -> RigParams:
    """`params` with one fitted field changed (the dowel's length carries its mass with it)."""
    if name == "dowel_length_m":
        return params.with_dowel_length(value)
    return dataclasses.replace(params, **{name: value})


def fit_spread(fit: Identification, recordings: list[Recording], tolerance: float = DEFAULT_TOLERANCE,
               cost: Callable[[RigParams, float, list[Recording]], float] | None = None) -> dict[str, Interval]:
    """{field: (low, high)} over which the twin still matches `recordings` within `tolerance` of `fit`'s cost,
    each field walked alone from the fit; "latency_ms" too when the fit matched it (not on the device's
    clock, where the latency is measured, not fitted)."""

    replayed = fit.pwm_phase_ms is not None and on_device_clock(recordings)
    cost = cost or (replay_cost if replayed else matching_cost)
    last = fit.pwm_phase_ms if replayed else fit.latency_ms
    best = float(cost(fit.params, last, recordings))
    ceiling = best * (1 + tolerance)

    def matches(params: RigParams, latency_ms: float) -> bool:
        return guarded_cost(cost, params, latency_ms, recordings) <= ceiling

    def field_matches(name: str, log_offset: float) -> bool:
        return matches(with_field(fit.params, name, getattr(fit.params, name) * math.exp(log_offset)), last)

    def latency_matches(offset_ms: float) -> bool:
        return matches(fit.params, max(0.0, last + offset_ms))

    spread = {}
    for name in RIG_FIELDS:
        low, high = (max(_walk(functools.partial(field_matches, name), LOG_STEPS, sign), MIN_LOG_HALF_WIDTH)
                     for sign in (-1, 1))
        centre = getattr(fit.params, name)
        spread[name] = (centre * math.exp(-low), centre * math.exp(high))
    if not replayed:
        low, high = (_walk(latency_matches, LATENCY_STEPS_MS, sign) for sign in (-1, 1))
        spread["latency_ms"] = (max(0.0, last - low), last + high)
    return spread


def _walk(matches: Callable[[float], bool], steps: tuple[float, ...], sign: int) -> float:
    """The farthest of `steps` (taken in order, each times `sign`) that still matches, stopping at the first
    that does not."""
    reached = 0.0
    for step in steps:
        if not matches(sign * step):
            break
        reached = step
    return reached


def spread_table(fit: Identification, spread: dict[str, Interval]) -> dict[str, dict[str, float]]:
    """The report's rows: each field's fit and interval."""
    values = fit.values()
    return {name: {"fit": values[name], "low": low, "high": high} for name, (low, high) in spread.items()}


class AroundTheFit(gym.Wrapper):
    """Before every reset, a rig drawn from `spread` about `fit` (log-uniformly; latency uniformly, as the
    network's floor) behind a network from the kit's training ranges, or behind the network measured with the
    recordings when the fit has one (`Identification.network`). A policy reading the observer's
    estimate keeps its observer designed for `observer_params` (default the fit: what the laptop knows of the
    rig)."""

    def __init__(self, env: gym.Env, fit: Identification, spread: dict[str, Interval], seed: int = 0,
                 observer_params: RigParams | tuple[RigParams, ...] | None = None) -> None:

        super().__init__(env)
        base = env.unwrapped
        if base.observes:
            base.pin_observer(observer_params or fit.params)
        self.fit, self.spread = fit, spread
        self.fidelity = resolve_fidelity(base.backend.fidelity)
        self.rng = np.random.default_rng(seed)
        self.drawn: RigParams | None = None

    def draw(self) -> tuple[RigParams, NetworkImpairment]:
        params = self.fit.params
        for name in RIG_FIELDS:
            if name in self.spread:
                low, high = self.spread[name]
                params = with_field(params, name, math.exp(self.rng.uniform(math.log(low), math.log(high))))
        floor_ms = float(self.rng.uniform(*self.spread.get("latency_ms", (self.fit.latency_ms,) * 2)))
        # measured with the recordings: the rig's own, not the class's ranges (the floor drawn above all the same,
        # so that the rigs drawn are those drawn without it)
        if self.fit.network is not None:
            return params, self.fit.network
        ranges = TRAINING_RANGES
        latency = LatencyModel(floor_ms=floor_ms, median_ms=float(self.rng.uniform(*ranges.latency_median_ms)),
                               spread=float(self.rng.uniform(*ranges.latency_spread)))
        loss = [float(self.rng.uniform(*ranges.loss_pct)) for _ in range(2)]
        return params, NetworkImpairment(latency, *loss)

    def reset(self, **kwargs):
        params, network = self.draw()
        self.drawn = params
        self.env.unwrapped.set_rig(params, dataclasses.replace(self.fidelity, name="around-the-fit", network=network))
        return self.env.reset(**kwargs)
