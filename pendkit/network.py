"""The network between the MCU and the host, one model for every backend: latency (a parametric default or
samples measured on a rig) and lost messages (`NetworkImpairment`); the messages' way through it, losses
and in-order delivery from one random stream (`NetworkPath`, used by the realistic twin and the virtual rig
alike). The delays a backend tells its controllers are worked out from these in `pendkit.timing`."""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendkit.errors import ConfigError

# Beyond this a message is lost, not late: the rig's watchdog stops the servo after 0.5 s without commands.
MAX_LATENCY_MS = 5_000.0


@dataclass(frozen=True)
class LatencyModel:
    """One-way latency in ms: `floor_ms` + lognormal(median `median_ms`, shape `spread`), or drawn
    from `samples_ms` when given (e.g. measured with the rig backend's episode logs).

    The default realistic figures (2 ms floor, 6 ms median above it, spread 0.6: p99 about 18 ms) are an
    assumption for an ESP32 on a busy classroom WiFi; load your own measurement with `from_file`.
    """

    floor_ms: float = 0.0
    median_ms: float = 0.0
    spread: float = 0.0
    samples_ms: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        for name, high in (("floor_ms", MAX_LATENCY_MS), ("median_ms", MAX_LATENCY_MS), ("spread", 5.0)):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 <= value <= high):
                raise ConfigError(f"LatencyModel.{name} must be in [0, {high:g}], got {value!r}")
        if any(not (math.isfinite(s) and 0 <= s <= MAX_LATENCY_MS) for s in self.samples_ms):
            raise ConfigError(f"LatencyModel.samples_ms must all be in [0, {MAX_LATENCY_MS:g}] ms")

    @property
    def is_zero(self) -> bool:
        return not self.samples_ms and self.floor_ms == 0 and self.median_ms == 0

    def sample_ms(self, rng: np.random.Generator) -> float:
        if self.samples_ms:
            return float(self.samples_ms[rng.integers(len(self.samples_ms))])
        if self.median_ms == 0:
            return self.floor_ms
        return self.floor_ms + self.median_ms * math.exp(self.spread * rng.standard_normal())

    @classmethod
    def from_file(cls, path: str | Path) -> LatencyModel:
        """Load samples in ms: a JSON list, or a text/CSV file with one number per line (header allowed)."""
        text = Path(path).read_text()
        try:
            values = json.loads(text)
        except json.JSONDecodeError:
            values = []
            for line in text.splitlines():
                cell = line.split(",")[0].strip()
                try:
                    values.append(float(cell))
                except ValueError:
                    continue
        if not values:
            raise ConfigError(f"no latency samples (ms) found in {path}")
        return cls(samples_ms=tuple(float(v) for v in values))


NO_LATENCY = LatencyModel()
CLASSROOM_WIFI = LatencyModel(floor_ms=2.0, median_ms=6.0, spread=0.6)


@dataclass(frozen=True)
class NetworkImpairment:
    """What the rig's WiFi adds: one-way latency (both ways, or `observation_latency` for readings only)
    and lost messages in percent (MQTT QoS 0 drops, it never resends)."""

    latency: LatencyModel = NO_LATENCY
    observation_loss_pct: float = 0.0
    command_loss_pct: float = 0.0
    observation_latency: LatencyModel | None = None

    def __post_init__(self) -> None:
        for name in ("observation_loss_pct", "command_loss_pct"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0 <= value <= 100):
                raise ConfigError(f"{name} must be in [0, 100], got {value!r}")

    @property
    def observation_latency_model(self) -> LatencyModel:
        return self.latency if self.observation_latency is None else self.observation_latency

    @property
    def is_perfect(self) -> bool:
        return (self.latency.is_zero and self.observation_latency_model.is_zero
                and self.observation_loss_pct == 0 and self.command_loss_pct == 0)

    def replace(self, **changes) -> NetworkImpairment:
        return dataclasses.replace(self, **changes)


PERFECT_NETWORK = NetworkImpairment()
IMPAIRMENTS: dict[str, NetworkImpairment] = {
    "none": PERFECT_NETWORK,
    "classroom-wifi": NetworkImpairment(CLASSROOM_WIFI, 0.2, 0.2),
    "poor-wifi": NetworkImpairment(LatencyModel(floor_ms=4.0, median_ms=15.0, spread=0.8), 3.0, 3.0),
}


def median_latency_ms(latency: LatencyModel) -> float:
    """The model's median one-way latency in ms (of the samples, or floor + lognormal median)."""
    if latency.samples_ms:
        return float(np.median(latency.samples_ms))
    return latency.floor_ms + latency.median_ms


COMMANDS, READINGS = 0, 1  # the two ways through a path


class NetworkPath:
    """Messages both ways through `impairment`, in the device's clock (ms): each one lost (QoS 0) or
    delivered after its latency, never before one sent earlier the same way (TCP keeps order). One random
    stream for both ways, drawn only for what can vary, so a seed gives the twin and the virtual rig the
    same draws."""

    def __init__(self, impairment: NetworkImpairment, rng: np.random.Generator) -> None:
        self.impairment, self.rng = impairment, rng
        self._last_ms = [0.0, 0.0]  # the latest arrival each way (COMMANDS, READINGS)

    @property
    def impairment(self) -> NetworkImpairment:
        return self._impairment

    @impairment.setter
    def impairment(self, impairment: NetworkImpairment) -> None:
        # read for every message the realistic twin sends (several a step): each way's model taken once
        self._impairment = impairment
        self._latency = (impairment.latency, impairment.observation_latency_model)
        self._loss_pct = (impairment.command_loss_pct, impairment.observation_loss_pct)

    def restart(self, rng: np.random.Generator | None = None) -> None:
        """A new episode: order starts afresh (and the stream, when given)."""
        self.rng = rng if rng is not None else self.rng
        self._last_ms = [0.0, 0.0]

    def _lost(self, loss_pct: float) -> bool:
        return loss_pct > 0 and self.rng.random() * 100 < loss_pct

    def _arrival_ms(self, way: int, sent_ms: float) -> float | None:
        loss_pct = self._loss_pct[way]
        if loss_pct and self._lost(loss_pct):
            return None
        arrival_ms, last_ms = sent_ms + self._latency[way].sample_ms(self.rng), self._last_ms
        if arrival_ms > last_ms[way]:
            last_ms[way] = arrival_ms
        return last_ms[way]

    def command_arrival_ms(self, sent_ms: float) -> float | None:
        """When a command sent at `sent_ms` reaches the device; None when it is lost."""
        return self._arrival_ms(COMMANDS, sent_ms)

    def observation_delivery_ms(self, sent_ms: float) -> float | None:
        """When a reading published at `sent_ms` reaches the host; None when it is lost."""
        return self._arrival_ms(READINGS, sent_ms)

