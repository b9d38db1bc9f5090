"""Energy pumping (Astrom & Furuta 2000) caught by LQR: the kit's first swing-up, on the laptop
(`pendkit.control.swingup`) and on the rig's device (`pendkit.deploy.swingup_design`)."""

from __future__ import annotations

from pendkit.control.swingup import SwingUpController
from pendkit.deploy.controllers import ClassicalController
from pendkit.deploy.swingup_design import swing_up_blob


def _design(params, config=None, weights=None, limits=None, observer_gains=None):
    return swing_up_blob(params, config, weights, observer_gains)


CONTROLLER = ClassicalController("energy", "energy", "energy swing-up + LQR", "Energy swing-up and LQR balance",
                                 SwingUpController.for_env, _design, in_adapt=True)
