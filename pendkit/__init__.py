"""pendkit: a teaching kit for a low-cost swing-up pendulum, its MuJoCo twin and the labs around it."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from pendkit.sim.render import choose_gl_backend

choose_gl_backend()  # must run before mujoco is first imported: it reads MUJOCO_GL at import time

import gymnasium  # noqa: E402

from pendkit.env import ENV_ID, SwingUpEnv  # noqa: E402
from pendkit.errors import ActionError, ConfigError, PendkitError  # noqa: E402
from pendkit.rig import RigParams  # noqa: E402
from pendkit.sim.fidelity import FIDELITY_PRESETS, Fidelity  # noqa: E402

try:
    __version__ = version("pendkit")
except PackageNotFoundError:  # running from a source tree without installing
    __version__ = "0.0.0+source"

if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="pendkit.env:SwingUpEnv")


def make(**kwargs) -> gymnasium.Env:
    """`gymnasium.make("pendkit/SwingUp-v0", **kwargs)`: e.g. `pendkit.make(fidelity="realistic")`."""
    return gymnasium.make(ENV_ID, **kwargs)


__all__ = ["ENV_ID", "FIDELITY_PRESETS", "ActionError", "ConfigError", "Fidelity", "PendkitError",
           "RigParams", "SwingUpEnv", "__version__", "make"]
