"""(e) Short trials on the rig's own device, to settle what the recordings leave open.

The excitation pins down the servo's speed and the pendulum well (within a few percent), but not the servo's
loop: a stiffer, less damped loop and a softer, better damped one move the pendulum almost alike in a free
swing, while the balance feels the difference (docs/rl.md: the identified loop across seeds). So the device's
two swing-up designs are made on the identified twin and on twins whose loop is twice as stiff or as soft,
or less or more damped, and each is tried for one short episode on the rig; the two that held best are tried
once more, and the one whose worse trial held best is the design the session evaluates.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pendkit.features import UPRIGHT_RAD
from pendkit.rig import RigParams

TRIAL_STEPS = 150  # 9 s at 60 ms: time for either swing-up to come up, and 6 s of balance after a quick one
TAIL_STEPS = 100  # the steps a trial is judged on: the balance, not the swing-up
CONFIRMED = 2  # the best trials are run once more: one lucky episode does not choose the design
# (label, multiples of the identified servo loop's full-torque error and damping ratio)
LOOP_VARIANTS = (("identified", 1.0, 1.0), ("stiffer loop", 0.5, 1.0), ("softer loop", 2.0, 1.0),
                 ("less damped loop", 1.0, 0.6), ("more damped loop", 1.0, 1.6))
CONTROLLERS = ("energy", "trajopt")
MAX_DAMPING_RATIO = 1.5


def loop_variant(params: RigParams, error_scale: float, damping_scale: float) -> RigParams:
    return dataclasses.replace(
        params, servo_full_torque_error_deg=params.servo_full_torque_error_deg * error_scale,
        servo_damping_ratio=min(MAX_DAMPING_RATIO, params.servo_damping_ratio * damping_scale))


def trial_score(angles_from_upright_rad) -> tuple[float, float]:
    """(fraction of the last TAIL_STEPS within the upright band, minus the largest angle among them): how
    well the balance held, then by how much margin. Higher is better."""
    tail = np.abs(np.asarray(angles_from_upright_rad, dtype=float))[-TAIL_STEPS:]
    return float(np.mean(tail < UPRIGHT_RAD)), -float(tail.max())


@dataclass
class Design:
    """One candidate: a device swing-up (`controller`) designed on `params`, its blob once made, and its
    trials' angles."""

    label: str
    controller: str
    params: RigParams
    blob: bytes | None = None
    trials: list[list[float]] = dataclasses.field(default_factory=list)

    @property
    def score(self) -> tuple[float, float]:
        """The worst of its trials: a design is as good as its worse episode."""
        return min(trial_score(angles) for angles in self.trials) if self.trials else (-1.0, -np.inf)

    def summary(self) -> dict:
        held, margin = self.score
        return {"label": self.label, "controller": self.controller, "trials": len(self.trials),
                "tail_held": held, "tail_max_rad": -margin}


def candidate_designs(params: RigParams) -> list[Design]:
    return [Design(label, controller, loop_variant(params, error, damping))
            for label, error, damping in LOOP_VARIANTS for controller in CONTROLLERS]


def trial_count() -> int:
    return len(LOOP_VARIANTS) * len(CONTROLLERS) + CONFIRMED


def try_on_device(run_on_device: Callable[..., list[list[float]]], params: RigParams,
                  say: Callable[[str], None] = print) -> tuple[Design | None, list[Design]]:
    """Every candidate design once on the rig's device, the best `CONFIRMED` once more; (the finalist whose
    worse trial held best, all of them). A design that cannot be made or uploaded is left out; None when
    none could be."""
    from pendkit.device.controller_blob import pack
    from pendkit.device.swingup_design import design_swing_up
    from pendkit.errors import PendkitError

    designs = candidate_designs(params)
    for design in designs:
        try:
            design.blob = pack(design_swing_up(design.params, design.controller))
            design.trials += run_on_device(design.blob, 1, TRIAL_STEPS)
        except (PendkitError, ValueError, ArithmeticError) as error:  # a design python-control cannot make
            say(f"(e) {design.label}, {design.controller}: not tried ({error})")
    finalists = [d for d in sorted(designs, key=lambda d: d.score, reverse=True)[:CONFIRMED] if d.trials]
    for design in finalists:
        design.trials += run_on_device(design.blob, 1, TRIAL_STEPS)
    return (max(finalists, key=lambda d: d.score) if finalists else None), designs
