"""The minimum-time swing-up: the fastest bang-bang plan from rest, tracked by time-varying LQR, energy
pumping where no plan reaches upright (`pendkit.control.tracking`); on the device the same plan and gains."""

from __future__ import annotations

from pendkit.control.tracking import TrajectoryController
from pendkit.deploy.controllers import ClassicalController
from pendkit.deploy.swingup_design import swing_up_blob, with_plan_from_rest


def _design(params, config=None, weights=None, limits=None, observer_gains=None):
    return with_plan_from_rest(swing_up_blob(params, config, weights, observer_gains), params, limits)


def _note(blob) -> str | None:
    if not blob.plan_steps:
        return "no swing-up from rest within 40 steps for this rig: the blob pumps energy from the start"
    return None


CONTROLLER = ClassicalController("trajopt", "minimum-time", "minimum-time swing-up",
                                 "Minimum-time swing-up (tracked plan) and LQR", TrajectoryController.for_env, _design,
                                 in_adapt=True, design_note=_note)
