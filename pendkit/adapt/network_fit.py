"""The rig's network as its excitation logs show it: the readings' delays about their median and the share of
readings that never arrived, each reading carrying the device's clock beside the host's.

The device streams on a fixed period, so a gap of k periods between two readings that arrived is k - 1
readings lost; the host's arrival time minus the device's time is the one-way delay plus a constant clock
offset, so its spread about the median is the delay's spread. Centred on the identified one-way latency,
those delays become the twin's latency samples, both ways (a command's delay cannot be seen alone: the same
WiFi is assumed both ways), and the readings' loss the loss of both.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pendkit.network import MAX_LATENCY_MS, LatencyModel, NetworkImpairment

MIN_READINGS = 20  # fewer arrived readings say nothing of a network's spread
BURST_MS = 0.5  # readings this close arrived together, the later one held up behind the earlier


def measured_network(recordings: Sequence, latency_ms: float) -> NetworkImpairment | None:
    """The network behind `recordings` (with device traces that kept the host's times), its delays centred on
    `latency_ms`; None when the recordings do not carry both clocks."""
    delays_ms: list[np.ndarray] = []
    arrived = lost = 0
    for recording in recordings:
        trace = getattr(recording, "device", None)
        if trace is None or len(trace.host_ms) != len(trace.ms) or len(trace.ms) < 3:
            continue
        # the first reading is the one from before the episode (the pendulum at rest): a wait, not a loss
        device_ms, host_ms = np.asarray(trace.ms[1:]), np.asarray(trace.host_ms[1:])
        offset_ms = host_ms - device_ms
        # a reading that arrived with the one before it waited behind it (the link keeps order): its own delay
        # was shorter than it looks, and the twin adds that wait itself, so only the readings that came alone count
        alone = np.concatenate([[True], np.diff(host_ms) > BURST_MS])
        delays_ms.append(offset_ms[alone] - np.median(offset_ms[alone]))
        steps_ms = np.diff(device_ms)
        period_ms = float(np.median(steps_ms)) if len(steps_ms) else 0.0
        if period_ms > 0:
            lost += int(np.sum(np.clip(np.round(steps_ms / period_ms) - 1, 0, None)))
        arrived += len(device_ms)
    if arrived < MIN_READINGS:
        return None
    samples = np.clip(latency_ms + np.concatenate(delays_ms), 0.0, MAX_LATENCY_MS)
    loss_pct = 100.0 * lost / (arrived + lost)
    return NetworkImpairment(LatencyModel(samples_ms=tuple(float(s) for s in samples)), loss_pct, loss_pct)


def described(network: NetworkImpairment) -> str:
    """One line for the report: the delays' median and 99th percentile, and the loss."""
    samples = np.asarray(network.latency.samples_ms)
    return (f"one-way delay median {np.median(samples):.0f} ms, p99 {np.percentile(samples, 99):.0f} ms, "
            f"{network.observation_loss_pct:.1f}% lost")
