"""(e) Trials on the rig's own device, to settle what the recordings leave open.

The excitation pins down the servo's speed and the pendulum well (within a few percent), but not always the
servo's loop: a stiffer, less damped loop and a softer, better damped one move the pendulum almost alike in a
free swing, while the balance feels the difference (docs/rl.md: the identified loop across seeds). So the
device's two swing-up designs are made on the identified twin and on twins whose loop is twice as stiff or
as soft, or less or more damped. Each is screened in one short episode on the rig; the best `FINALISTS` then
run one whole episode each, judged by the kit's "solved" rule, because a balance that holds for six seconds
can still fall later. Ties go to the identified twin's designs.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from pendkit.agents.runs import SOLVED_TAIL_STEPS, held_fraction
from pendkit.deploy.controllers import adapt_controllers
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack
from pendkit.env_name import EPISODE_STEPS
from pendkit.errors import PendkitError
from pendkit.features import UPRIGHT_RAD, holds_upright
from pendkit.rig import RigParams

SCREEN_STEPS = 200  # 12 s at 60 ms: time for the slower swing-up to come up, and 6 s of balance after it
TAIL_STEPS = 100  # the screening steps a design is judged on: the balance, not the swing-up
FINALISTS = 3  # the best screened designs, each run for a whole episode
# (label, multiples of the identified servo loop's full-torque error and damping ratio)
LOOP_VARIANTS = (("identified", 1.0, 1.0), ("stiffer loop", 0.5, 1.0), ("softer loop", 2.0, 1.0),
                 ("less damped loop", 1.0, 0.6), ("more damped loop", 1.0, 1.6))
CONTROLLERS = tuple(c.name for c in adapt_controllers())
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
    trials' angles: the screening episode first, then the whole one if it was a finalist."""

    label: str
    controller: str
    params: RigParams
    blob: bytes | None = None
    trials: list[list[float]] = dataclasses.field(default_factory=list)

    @property
    def screening(self) -> tuple[float, float]:
        return trial_score(self.trials[0]) if self.trials else (-1.0, -np.inf)

    @property
    def whole_episode(self) -> tuple[float, float]:
        """(1 if the whole episode was solved, else 0; the fraction held after the swing-up); (-1, -1) when
        it did not run one."""
        if len(self.trials) < 2:
            return -1.0, -1.0
        angles = self.trials[-1]
        return float(holds_upright(angles, SOLVED_TAIL_STEPS)), held_fraction(angles) or 0.0

    @property
    def rank(self) -> tuple:
        """Finalists first, by their whole episode; then the screening; ties to the identified twin's."""
        return (*self.whole_episode, *self.screening, self.label == LOOP_VARIANTS[0][0])

    def summary(self) -> dict:
        held, margin = self.screening
        solved, held_whole = self.whole_episode
        return {"label": self.label, "controller": self.controller, "trials": len(self.trials),
                "screen_held": held, "screen_max_rad": -margin,
                "whole_solved": None if solved < 0 else bool(solved),
                "whole_held": None if held_whole < 0 else held_whole}


def candidate_designs(params: RigParams) -> list[Design]:
    return [Design(label, controller, loop_variant(params, error, damping))
            for label, error, damping in LOOP_VARIANTS for controller in CONTROLLERS]


def trial_steps() -> int:
    """The rig's control steps the trials take at most (each episode also counts its reset step)."""
    return len(LOOP_VARIANTS) * len(CONTROLLERS) * (SCREEN_STEPS + 1) + FINALISTS * (EPISODE_STEPS + 1)


def make_designs(params: RigParams, say: Callable[[str], None] = print) -> list[Design]:
    """Every candidate with its blob; one python-control cannot make keeps no blob (and is said)."""
    return [with_blob(design, say) for design in candidate_designs(params)]


def with_blob(design: Design, say: Callable[[str], None] = print) -> Design:
    """`design` with its blob made; without one (and said) when python-control cannot make it."""

    try:
        design.blob = pack(design_swing_up(design.params, design.controller))
    except (PendkitError, ValueError, ArithmeticError) as error:
        say(f"(e) {design.label}, {design.controller}: not made ({error})")
    return design


def identified_design(params: RigParams, say: Callable[[str], None] = print) -> Design | None:
    """Without trials: the identified twin's minimum-time design (its energy design when python-control cannot
    make that one); None when neither can be made."""
    for controller in reversed(CONTROLLERS):
        design = with_blob(Design(LOOP_VARIANTS[0][0], controller, params), say)
        if design.blob is not None:
            return design
    return None


def run_trials(designs: list[Design], run_on_device: Callable[..., list[list[float]]],
               say: Callable[[str], None] = print, screen_steps: int = SCREEN_STEPS,
               finalists: int = FINALISTS) -> Design | None:
    """Screen every design that has a blob on the rig's device for `screen_steps`, run the best `finalists`
    for a whole episode; the best finalist, None when no design could be run (the device refused each)."""

    for design in (d for d in designs if d.blob is not None):
        try:
            design.trials += run_on_device(design.blob, 1, screen_steps)
        except PendkitError as error:  # the device refused it, or it never arrived whole
            say(f"(e) {design.label}, {design.controller}: not tried ({error})")
    best = [d for d in sorted(designs, key=lambda d: d.rank, reverse=True)[:finalists] if d.trials]
    for design in best:
        design.trials += run_on_device(design.blob, 1, EPISODE_STEPS)
    return max(best, key=lambda d: d.rank) if best else None


def try_on_device(run_on_device: Callable[..., list[list[float]]], params: RigParams,
                  say: Callable[[str], None] = print) -> tuple[Design | None, list[Design]]:
    """The candidate designs made on `params` and tried on the rig's device: (the chosen one, all of them)."""
    designs = make_designs(params, say)
    return run_trials(designs, run_on_device, say), designs
