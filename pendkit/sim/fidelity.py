"""Named fidelity presets of the twin: each imperfection is a setting, not an `if` inside `step()`."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from pendkit.backend_contract import BackendTiming
from pendkit.errors import ConfigError
from pendkit.network import CLASSROOM_WIFI, PERFECT_NETWORK, LatencyModel, NetworkImpairment, median_latency_ms
from pendkit.timing import host_timing


def _is_int(value) -> bool:
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


@dataclass(frozen=True)
class Fidelity:
    """How closely the twin imitates the real rig's sensing and actuation.

    substeps_per_step: physics steps before the observation is taken (None: RigParams.frame_skip).
    post_observation_substeps_max: after the observation, 0..this many more physics steps run with the
        same action before the next one arrives (the paper's delayed sim uses 2).
    mcu_pipeline: run the firmware's loop (acting and streaming ticks, counts, quantised encoder,
        estimated velocities, PWM frames, safety stops) instead of reading the true state.
    encoder_mount_offset_counts: raw encoder reading when the pendulum hangs (calibrated away by the MCU).
    encoder_residual_offset_counts: what that calibration missed: a hanging pendulum reads this many counts.
    network: latency and loss between device and host (only with `mcu_pipeline`), the same settings a
        virtual rig takes. `replace(latency=...)` is a shortcut for the network's latency.
    """

    name: str
    substeps_per_step: int | None = None
    post_observation_substeps_max: int = 0
    mcu_pipeline: bool = False
    encoder_mount_offset_counts: int = 0
    encoder_residual_offset_counts: int = 0
    network: NetworkImpairment = PERFECT_NETWORK

    def __post_init__(self) -> None:
        if self.substeps_per_step is not None and not (_is_int(self.substeps_per_step)
                                                       and 1 <= self.substeps_per_step <= 1000):
            raise ConfigError(f"substeps_per_step must be None or a whole number in [1, 1000], "
                              f"got {self.substeps_per_step!r}")
        if not _is_int(self.post_observation_substeps_max):
            raise ConfigError(f"post_observation_substeps_max must be a whole number, "
                              f"got {self.post_observation_substeps_max!r}")
        if not 0 <= self.post_observation_substeps_max <= 100:
            raise ConfigError(f"post_observation_substeps_max must be in [0, 100], got "
                              f"{self.post_observation_substeps_max}")
        if not _is_int(self.encoder_residual_offset_counts) or abs(self.encoder_residual_offset_counts) > 64:
            raise ConfigError(f"encoder_residual_offset_counts must be a whole number in [-64, 64], got "
                              f"{self.encoder_residual_offset_counts!r}")
        if not isinstance(self.network, NetworkImpairment):
            raise ConfigError(f"network must be a NetworkImpairment, got {self.network!r}")
        if not self.mcu_pipeline and not self.network.is_perfect:
            raise ConfigError("a network (latency, loss) needs mcu_pipeline=True: it applies to MQTT messages")

    def replace(self, latency: LatencyModel | None = None, **changes) -> Fidelity:
        if latency is not None:
            changes["network"] = changes.get("network", self.network).replace(latency=latency)
        return dataclasses.replace(self, **changes)

    @property
    def latency(self) -> LatencyModel:
        return self.network.latency

    def nominal_step_s(self, params) -> float:
        """Mean duration of one env step on a rig of `params` (paper-delayed adds 0..max substeps)."""
        substeps = self.substeps_per_step or params.frame_skip
        return (substeps + self.post_observation_substeps_max / 2) * params.physics_step_ms / 1000.0

    def timing(self, params) -> BackendTiming:
        """What the twin tells its controllers. Ideal: no delays. Paper-delayed: the 0-2 substeps run after the
        observation (mean one) are reading delay. MCU pipeline: `pendkit.timing.host_timing` with the
        network's median latencies."""
        step_s = self.nominal_step_s(params)
        if not self.mcu_pipeline:
            return BackendTiming(step_s, 0.0, self.post_observation_substeps_max / 2 * params.physics_step_ms / 1000)
        return host_timing(params, step_s, median_latency_ms(self.network.latency),
                           median_latency_ms(self.network.observation_latency_model))


FIDELITY_PRESETS: dict[str, Fidelity] = {
    # The paper's easy sim: perfect sensing, 12 x 5 ms per step.
    "ideal": Fidelity("ideal"),
    # The paper's hard sim: observe after 6 substeps, then 0-2 more substeps with the same action.
    "paper-delayed": Fidelity("paper-delayed", substeps_per_step=6, post_observation_substeps_max=2),
    # The MCU's pipeline with the rig's periods and an assumed classroom WiFi latency.
    "realistic": Fidelity("realistic", mcu_pipeline=True, encoder_mount_offset_counts=317,
                          network=NetworkImpairment(CLASSROOM_WIFI)),
}


def observation_delay_fidelity(delay_ms: float) -> Fidelity:
    """The realistic MCU pipeline with a fixed observation latency of `delay_ms` and instant commands: one
    knob for delay sweeps (the velocities are still the firmware's estimates)."""
    network = NetworkImpairment(observation_latency=LatencyModel(floor_ms=delay_ms))
    return FIDELITY_PRESETS["realistic"].replace(name=f"obs-delay-{delay_ms:g}ms", network=network)


def resolve_fidelity(fidelity: str | Fidelity) -> Fidelity:
    """A preset by name, or a custom `Fidelity` as given."""
    if isinstance(fidelity, Fidelity):
        return fidelity
    try:
        return FIDELITY_PRESETS[fidelity]
    except (KeyError, TypeError):
        raise ConfigError(f"unknown fidelity {fidelity!r}; expected one of {sorted(FIDELITY_PRESETS)} "
                          f"or a pendkit.sim.Fidelity") from None
