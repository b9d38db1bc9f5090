"""Domain randomisation for sim-to-real: a new rig (servo, masses, pendulum, pulses, encoder calibration,
network) every episode.

The paper's authors found that a policy trained on one servo did not transfer to another. Training over a
spread of rigs makes a policy that works for any of them, and a policy with a memory (R-DQN's GRU) can
infer the rig it is on from what it has seen (rapid motor adaptation: a history-conditioned policy trained
over many dynamics). What varies, and why (`TRAINING_RANGES`; docs/adapt.md has the table):

- servo: speed, stall torque, its loop's stiffness and damping from the smallest to the largest of the kit's
  presets (`preset_ranges`: today 0.12-0.28 s/60 deg, 6-25.5 kg cm, 1-5 deg, 0.2-0.7);
- masses: each +-20% (another aluminium tube, a heavier encoder), the tip weight 0.6-1.8x (reprinted at
  another infill, or with a nut inside);
- pendulum: the dowel 0.30-0.45 m long (cut short, or a longer stock piece; its mass follows its length),
  the bearing's damping 0.5-3x the default (a dry or a stiff encoder shaft);
- pulses: the servo's end counts between the presets' (the D645MW's and the Turnigy's ranges: a worn horn
  or a servo that needs a narrower range) and one preset's step sizes;
- encoder: a residual calibration error of up to 6 counts (2 degrees) after `o<offset>`;
- network: from none to the virtual rig's poor WiFi (`network_ranges`: its latency floor, median above it,
  spread and loss).

`held_out_rigs(n, seed)` draws rigs from ranges 20% wider (`widened(1.2)`), for evaluation only.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

from pendkit.errors import ConfigError
from pendkit.network import IMPAIRMENTS, LatencyModel, NetworkImpairment
from pendkit.rig import SERVO_PRESETS, RigParams
from pendkit.sim.fidelity import Fidelity, resolve_fidelity

RANDOMIZABLE = ("servo", "latency", "masses", "pendulum", "pulses", "encoder", "network")
# "robust": everything at once (the r-dqn-robust policy's training); "network" is latency and loss.
ALIASES = {"robust": ("servo", "masses", "pendulum", "pulses", "encoder", "network")}
SERVO_FIELDS = ("servo_speed_s_per_60deg", "servo_stall_torque_kg_cm", "servo_full_torque_error_deg",
                "servo_damping_ratio")
STEP_FIELDS = ("discrete_slow_step_counts", "discrete_fast_step_counts")
MASS_FIELDS = tuple(f.name for f in dataclasses.fields(RigParams) if f.name.endswith("_mass_kg"))
Range = tuple[float, float]
WORST_NETWORK = "poor-wifi"  # the network ranges run from none to this impairment's figures


def preset_ranges(presets: dict = SERVO_PRESETS) -> dict[str, Range]:
    """Each servo field (and the pulse ends) from its smallest to its largest value over the servo presets."""
    rigs = [RigParams(**changes) for changes in presets.values()]
    return {name: (min(getattr(r, name) for r in rigs), max(getattr(r, name) for r in rigs))
            for name in (*SERVO_FIELDS, "servo_min_counts", "servo_max_counts")}


def network_ranges(worst: NetworkImpairment = IMPAIRMENTS[WORST_NETWORK]) -> dict[str, Range]:
    """From a perfect network to `worst`: its latency floor, median above it, spread and the larger loss."""
    return {"latency_floor_ms": (0.0, worst.latency.floor_ms), "latency_median_ms": (0.0, worst.latency.median_ms),
            "latency_spread": (0.0, worst.latency.spread),
            "loss_pct": (0.0, max(worst.command_loss_pct, worst.observation_loss_pct))}


_PRESETS, _NETWORK = preset_ranges(), network_ranges()


@dataclass(frozen=True)
class RigRanges:
    """Uniform ranges of what differs from rig to rig (scales multiply the base rig's value); the servo's,
    the pulses' and the network's defaults come from the presets (`preset_ranges`, `network_ranges`)."""

    servo_speed_s_per_60deg: Range = _PRESETS["servo_speed_s_per_60deg"]
    servo_stall_torque_kg_cm: Range = _PRESETS["servo_stall_torque_kg_cm"]
    servo_full_torque_error_deg: Range = _PRESETS["servo_full_torque_error_deg"]
    servo_damping_ratio: Range = _PRESETS["servo_damping_ratio"]
    mass_scale: Range = (0.8, 1.2)
    tip_mass_scale: Range = (0.6, 1.8)
    dowel_length_m: Range = (0.30, 0.45)
    pendulum_damping_scale: Range = (0.5, 3.0)
    servo_min_counts: Range = _PRESETS["servo_min_counts"]
    servo_max_counts: Range = _PRESETS["servo_max_counts"]
    residual_offset_counts: Range = (-6, 6)
    latency_floor_ms: Range = _NETWORK["latency_floor_ms"]
    latency_median_ms: Range = _NETWORK["latency_median_ms"]
    latency_spread: Range = _NETWORK["latency_spread"]
    loss_pct: Range = _NETWORK["loss_pct"]

    def widened(self, factor: float) -> RigRanges:
        """Every range `factor` times as wide about its centre, kept physical (positive, counts ordered)."""
        if factor == 1:
            return self
        floors = {"servo_speed_s_per_60deg": 0.05, "servo_stall_torque_kg_cm": 1.0,
                  "servo_full_torque_error_deg": 0.2, "servo_damping_ratio": 0.05, "mass_scale": 0.1,
                  "tip_mass_scale": 0.1, "dowel_length_m": 0.15, "pendulum_damping_scale": 0.1,
                  "servo_min_counts": 100, "servo_max_counts": 301, "residual_offset_counts": -64,
                  "latency_floor_ms": 0.0, "latency_median_ms": 0.0, "latency_spread": 0.0, "loss_pct": 0.0}
        ceilings = {"servo_min_counts": 299, "servo_max_counts": 500, "residual_offset_counts": 64, "loss_pct": 50.0}
        changes = {}
        for field in dataclasses.fields(self):
            low, high = getattr(self, field.name)
            centre, half = (low + high) / 2, (high - low) / 2 * factor
            changes[field.name] = (max(floors[field.name], centre - half),
                                   min(ceilings.get(field.name, float("inf")), centre + half))
        return RigRanges(**changes)


TRAINING_RANGES = RigRanges()
# The servos' pulse tables a drawn rig takes one of (slow and fast step counts, end counts), frozen here
# rather than read from the presets: a preset added to the kit must not shift the robust policy's training
# rigs or its held-out ones. These are the five presets' tables in their names' order when this was written.
PULSE_TABLES = ((2, 4, 150, 450), (2, 4, 150, 450), (2, 4, 150, 450), (2, 4, 150, 450), (1, 2, 200, 400))
PULSE_FIELDS = (*STEP_FIELDS, "servo_min_counts", "servo_max_counts")
HELD_OUT_WIDENING = 1.2


def parse_randomize(text: str) -> tuple[str, ...]:
    """'servo,latency' -> ('servo', 'latency'); 'robust' -> everything; '' -> ()."""
    names: list[str] = []
    for name in (n.strip() for n in text.split(",") if n.strip()):
        names += ALIASES.get(name, (name,))
    unknown = [n for n in names if n not in RANDOMIZABLE]
    if unknown:
        raise ConfigError(f"cannot randomise {unknown}; choose from {', '.join(RANDOMIZABLE)} (or robust: all)")
    return tuple(dict.fromkeys(names))


def _uniform(rng: np.random.Generator, bounds: Range) -> float:
    return float(rng.uniform(*bounds))


@dataclass(frozen=True)
class RandomRig:
    """One drawn rig: its parameters and what the twin's fidelity adds (network, calibration error)."""

    params: RigParams
    network: NetworkImpairment | None = None
    residual_offset_counts: int = 0

    def fidelity(self, base: Fidelity) -> Fidelity:
        changes = {"name": "randomised", "encoder_residual_offset_counts": self.residual_offset_counts}
        if self.network is not None:
            changes["network"] = self.network
        return dataclasses.replace(base, **changes)


def sample_rig(base: RigParams, what: tuple[str, ...], rng: np.random.Generator,
               ranges: RigRanges = TRAINING_RANGES) -> RandomRig:
    """A rig with the fields `what` names drawn from `ranges`, the rest as `base`."""
    changes: dict = {}
    if "servo" in what:
        changes.update({f: _uniform(rng, getattr(ranges, f)) for f in SERVO_FIELDS})
        changes["servo_name"] = "randomised"
    if "pulses" in what:
        steps = PULSE_TABLES[int(rng.integers(len(PULSE_TABLES)))]
        changes.update(zip(STEP_FIELDS, steps[:2]))
        changes["servo_min_counts"] = round(_uniform(rng, ranges.servo_min_counts))
        changes["servo_max_counts"] = round(_uniform(rng, ranges.servo_max_counts))
    elif "servo" in what:  # the servo presets' own pulses, as before "pulses" existed
        changes.update(zip(PULSE_FIELDS, PULSE_TABLES[int(rng.integers(len(PULSE_TABLES)))]))
    if "masses" in what:
        changes.update({f: getattr(base, f) * _uniform(rng, ranges.mass_scale) for f in MASS_FIELDS})
        changes["tip_mass_kg"] = base.tip_mass_kg * _uniform(rng, ranges.tip_mass_scale)
    length_m = None
    if "pendulum" in what:
        length_m = _uniform(rng, ranges.dowel_length_m)
        changes["pendulum_damping_n_m_s_per_rad"] = (base.pendulum_damping_n_m_s_per_rad
                                                     * _uniform(rng, ranges.pendulum_damping_scale))
    network = None
    if "latency" in what or "network" in what:
        latency = LatencyModel(floor_ms=_uniform(rng, ranges.latency_floor_ms),
                               median_ms=_uniform(rng, ranges.latency_median_ms),
                               spread=_uniform(rng, ranges.latency_spread))
        loss = (_uniform(rng, ranges.loss_pct), _uniform(rng, ranges.loss_pct)) if "network" in what else (0.0, 0.0)
        network = NetworkImpairment(latency, *loss)
    residual = round(_uniform(rng, ranges.residual_offset_counts)) if "encoder" in what else 0
    params = dataclasses.replace(base, **changes)
    return RandomRig(params if length_m is None else params.with_dowel_length(length_m), network, residual)


def held_out_rigs(count: int, seed: int = 2026, base: RigParams | None = None,
                  widening: float = HELD_OUT_WIDENING) -> list[RandomRig]:
    """Rigs for evaluation only: every field drawn from the training ranges widened by `widening` (1: the
    training ranges themselves)."""
    rng = np.random.default_rng(seed)
    ranges = TRAINING_RANGES.widened(widening)
    return [sample_rig(base or RigParams(), ALIASES["robust"], rng, ranges) for _ in range(count)]


BANK_SEED, BANK_SIZE = 7, 13  # the observer bank's candidate rigs: the nominal one and 12 from the training ranges


def observer_bank(size: int = BANK_SIZE, seed: int = BANK_SEED) -> tuple[RigParams, ...]:
    """Candidate rigs for a bank of observers (`pendkit.control.observer_bank`): the nominal rig and `size - 1`
    drawn from the training ranges (never the held-out or validation draws): how a policy whose observer is
    not designed for the nominal rig meets a rig nobody identified."""
    return (RigParams(), *(rig.params for rig in held_out_rigs(size - 1, seed, widening=1.0)))


class DomainRandomization(gym.Wrapper):
    """Before every reset, a new rig: `what` is a subset of RANDOMIZABLE (or "robust"). The network and
    the encoder's calibration need a fidelity with the MCU pipeline (it is what they act on). An env with
    `features="estimated"` keeps its observer designed for the base rig (as on a rig the laptop does not
    know), unless it was pinned to another; `observer_follows_rig=True` designs it for each drawn rig."""

    def __init__(self, env: gym.Env, what: tuple[str, ...] | str, seed: int = 0,
                 ranges: RigRanges = TRAINING_RANGES, observer_follows_rig: bool = False) -> None:
        super().__init__(env)
        self.what = parse_randomize(what if isinstance(what, str) else ",".join(what))
        base = env.unwrapped
        self.base_params, self.base_fidelity = base.params, resolve_fidelity(base.backend.fidelity)
        needs_mcu = {"latency", "network", "encoder"} & set(self.what)
        if needs_mcu and not self.base_fidelity.mcu_pipeline:
            raise ConfigError(f"randomising {', '.join(sorted(needs_mcu))} needs a fidelity with the MCU pipeline "
                              "(e.g. 'realistic')")
        if base.observes and not base.observer_pinned and not observer_follows_rig:
            base.pin_observer()
        self.ranges = ranges
        self.rng = np.random.default_rng(seed)
        self.rig: RandomRig | None = None

    def reset(self, **kwargs):
        self.rig = sample_rig(self.base_params, self.what, self.rng, self.ranges)
        fidelity = self.rig.fidelity(self.base_fidelity) if self.base_fidelity.mcu_pipeline else self.base_fidelity
        self.env.unwrapped.set_rig(self.rig.params, fidelity)
        return self.env.reset(**kwargs)
