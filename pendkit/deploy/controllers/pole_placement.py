"""Energy pumping caught by pole placement: the catch is a state feedback that puts the closed loop's poles
where they are asked to be (python-control's `place`) rather than where a cost puts them (LQR). The same
five states, so the device runs it in the swing-up blob as it is."""

from __future__ import annotations

import control
import numpy as np

from pendkit.control.swingup import SwingUpController
from pendkit.deploy.controllers import ClassicalController
from pendkit.deploy.swingup_design import swing_up_blob

# Per 60 ms step (z-plane): a fast pair for the pendulum, the filter's pole, a slow pair for the arm's drift.
POLES = (0.1 + 0.2j, 0.1 - 0.2j, 0.6, 0.8 + 0.05j, 0.8 - 0.05j)


def placed_gain(balancer, poles=POLES) -> np.ndarray:
    """The gain that places the poles of `balancer`'s discretised loop (the LQR's system) at `poles`."""
    system = balancer.system
    return np.atleast_2d(control.place(np.asarray(system.A), np.asarray(system.B), list(poles)))


class PolePlacementSwingUp(SwingUpController):
    """The laptop's energy swing-up with the placed catch in place of the LQR's."""

    @classmethod
    def for_env(cls, env, **kwargs) -> PolePlacementSwingUp:
        controller = super().for_env(env, **kwargs)
        controller.balancer.gain = placed_gain(controller.balancer)
        controller.balancer.closed_loop_poles = np.array(POLES)
        return controller


def _design(params, config=None, weights=None, limits=None, observer_gains=None):
    return swing_up_blob(params, config, weights, observer_gains, catch_gain=placed_gain)


CONTROLLER = ClassicalController("pole-placement", "pole-placement", "energy swing-up + pole placement",
                                 "Energy swing-up and a pole-placement catch", PolePlacementSwingUp.for_env, _design)
