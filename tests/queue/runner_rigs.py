"""What the runner tests share: hostile blobs, a runner served in a thread, waiting for the store to say so."""

from __future__ import annotations

import contextlib
import threading
import time

from pendkit.control.swingup import SwingUpConfig
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack
from pendkit.rig import RigParams

SPEED = 5.0  # virtual rigs' time per wall second: an episode of 400 steps (24 s) in about 5 s (at 10x and 20x a loaded
# 2-core machine let the rigs fall behind and fail their resets)
# a judged job of one short episode: 12 s to swing up (the energy design takes 3-6 s), then the rule's 200 steps
STEPS = 400
SHORT = {"episodes": 1, "episode_steps": STEPS}


def spinner_blob() -> bytes:
    """A swing-up that never catches and pumps bang-bang between the arm's end stops: the pendulum goes round."""
    blob = design_swing_up(RigParams(), "energy", config=SwingUpConfig(
        target_energy=10.0, swing_rate_rad_s=50.0, catch_angle_rad=0.01, catch_velocity_rad_s=0.01,
        fall_angle_rad=0.02))
    blob.scalars.update(arm_limit_rad=RigParams().servo_range_rad, energy_gain=10.0, centring_per_s=0.001)
    return pack(blob)


def network_blob() -> bytes:
    """A bare network (kind 1): the device's parser takes it, the device does not run it."""
    import numpy as np

    from pendkit.device.controller_blob import DenseLayer, NetworkBlob

    layer = DenseLayer(np.zeros((2, 3), np.float32), np.zeros(2, np.float32), "none")
    return pack(NetworkBlob(np.zeros(3, np.float32), np.ones(3, np.float32), 5.0, [layer]))


def wait_for(condition, timeout_s: float = 120.0, every_s: float = 0.05):
    """`condition()`'s first true value; AssertionError after `timeout_s` (a hung runner, not a slow one)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        found = condition()
        if found:
            return found
        time.sleep(every_s)
    raise AssertionError(f"not within {timeout_s:g} s: {getattr(condition, '__name__', condition)}")


@contextlib.contextmanager
def serving(runner):
    """The runner serving in a thread until the block ends."""
    thread = threading.Thread(target=runner.run, daemon=True)
    thread.start()
    try:
        yield runner
    finally:
        runner.stopping.set()
        thread.join(timeout=60)
