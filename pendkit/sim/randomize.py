"""Domain randomisation for sim-to-real: a new servo, network and set of masses every episode.

The paper's authors found that a policy trained on one servo did not transfer to another. Training over a
spread of servos makes the policy one that works for any of them. The ranges come from what the kit
already knows: the servo presets in `RigParams` (each servo field uniform between the presets' smallest
and largest value, the pulse range and step sizes of one preset), the network impairments of the virtual
rig (latency between none and poor WiFi), and +-10% on every mass (a heavier tip weight, another dowel).
"""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np

from pendkit.errors import ConfigError
from pendkit.rig import SERVO_PRESETS, RigParams
from pendkit.sim.fidelity import resolve_fidelity
from pendkit.sim.latency import LatencyModel

RANDOMIZABLE = ("servo", "latency", "masses")
SERVO_FIELDS = ("servo_speed_s_per_60deg", "servo_stall_torque_kg_cm", "servo_full_torque_error_deg",
                "servo_damping_ratio")
PULSE_FIELDS = ("servo_min_counts", "servo_max_counts", "discrete_slow_step_counts", "discrete_fast_step_counts")
MASS_FIELDS = tuple(f.name for f in dataclasses.fields(RigParams) if f.name.endswith("_mass_kg"))
MASS_SPREAD = 0.10
# Latency (ms) from none to the virtual rig's poor WiFi (floor 4, median 15 above it, spread 0.8).
LATENCY_FLOOR_MS = (0.0, 4.0)
LATENCY_MEDIAN_MS = (0.0, 15.0)
LATENCY_SPREAD = (0.0, 0.8)


def parse_randomize(text: str) -> tuple[str, ...]:
    """'servo,latency' -> ('servo', 'latency'); '' -> ()."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    unknown = [n for n in names if n not in RANDOMIZABLE]
    if unknown:
        raise ConfigError(f"cannot randomise {unknown}; choose from {', '.join(RANDOMIZABLE)}")
    return names


def _preset_range(field: str) -> tuple[float, float]:
    values = [getattr(RigParams.preset(name), field) for name in SERVO_PRESETS]
    return min(values), max(values)


def sample_rig(base: RigParams, what: tuple[str, ...], rng: np.random.Generator) -> RigParams:
    changes: dict = {}
    if "servo" in what:
        changes.update({f: float(rng.uniform(*_preset_range(f))) for f in SERVO_FIELDS})
        pulses = RigParams.preset(sorted(SERVO_PRESETS)[int(rng.integers(len(SERVO_PRESETS)))])
        changes.update({f: getattr(pulses, f) for f in PULSE_FIELDS})
        changes["servo_name"] = "randomised"
    if "masses" in what:
        changes.update({f: getattr(base, f) * float(rng.uniform(1 - MASS_SPREAD, 1 + MASS_SPREAD))
                        for f in MASS_FIELDS})
    return dataclasses.replace(base, **changes)


def sample_latency(rng: np.random.Generator) -> LatencyModel:
    return LatencyModel(floor_ms=float(rng.uniform(*LATENCY_FLOOR_MS)),
                        median_ms=float(rng.uniform(*LATENCY_MEDIAN_MS)), spread=float(rng.uniform(*LATENCY_SPREAD)))


class DomainRandomization(gym.Wrapper):
    """Before every reset, a new rig: `what` is a subset of RANDOMIZABLE. Latency needs a fidelity with the
    MCU pipeline (it is what the network delays)."""

    def __init__(self, env: gym.Env, what: tuple[str, ...] | str, seed: int = 0) -> None:
        super().__init__(env)
        self.what = parse_randomize(what) if isinstance(what, str) else tuple(what)
        parse_randomize(",".join(self.what))
        base = env.unwrapped
        self.base_params, self.base_fidelity = base.params, resolve_fidelity(base.backend.fidelity)
        if "latency" in self.what and not self.base_fidelity.mcu_pipeline:
            raise ConfigError("randomising latency needs a fidelity with the MCU pipeline (e.g. 'realistic')")
        self.rng = np.random.default_rng(seed)

    def reset(self, **kwargs):
        params = sample_rig(self.base_params, self.what, self.rng)
        fidelity = self.base_fidelity
        if "latency" in self.what:
            fidelity = fidelity.replace(name="randomised", latency=sample_latency(self.rng))
        self.env.unwrapped.set_rig(params, fidelity)
        return self.env.reset(**kwargs)
