"""pendkit: a teaching kit for a low-cost swing-up pendulum, its MuJoCo twin and the labs around it.

The env and the twin load on first use (`pendkit.make`, `pendkit.SwingUpEnv`): a lab that only decodes
encoder frames starts without MuJoCo, and so does each notebook the grader runs.
"""

from __future__ import annotations

import importlib
import numbers
from importlib.metadata import PackageNotFoundError, version

import gymnasium

from pendkit.env_name import ENV_ID, EPISODE_STEPS
from pendkit.errors import ActionError, ConfigError, PendkitError
from pendkit.gl_backend import choose_gl_backend

choose_gl_backend()  # must run before mujoco is first imported: it reads MUJOCO_GL at import time

try:
    __version__ = version("pendkit")
except PackageNotFoundError:  # running from a source tree without installing
    __version__ = "0.0.0+source"

if ENV_ID not in gymnasium.registry:
    # The TimeLimit wrapper is the one episode limit for made envs (so make(max_episode_steps=1000) holds).
    gymnasium.register(id=ENV_ID, entry_point="pendkit.env:SwingUpEnv", max_episode_steps=EPISODE_STEPS,
                       kwargs={"max_episode_steps": None})

_LAZY = {"SwingUpEnv": "pendkit.env", "RigParams": "pendkit.rig", "Fidelity": "pendkit.sim.fidelity",
         "FIDELITY_PRESETS": "pendkit.sim.fidelity"}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'pendkit' has no attribute {name!r}")


def make(**kwargs) -> gymnasium.Env:
    """`gymnasium.make("pendkit/SwingUp-v0", **kwargs)`: e.g. `pendkit.make(fidelity="realistic")`."""
    limit = kwargs.get("max_episode_steps", EPISODE_STEPS)  # gymnasium takes it for its TimeLimit: check it here
    if isinstance(limit, bool) or not isinstance(limit, numbers.Integral) or limit < 1:
        raise ConfigError(f"max_episode_steps must be a positive whole number (default {EPISODE_STEPS}), "
                          f"got {limit!r}")
    if "max_episode_steps" in kwargs:
        kwargs["max_episode_steps"] = int(limit)  # a numpy integer too
    if kwargs.get("render_mode") == "human":
        raise ConfigError("render_mode='human' (a window) is not offered: use render_mode='rgb_array' and show the "
                          "frames yourself, or watch live in a notebook with pendkit.widgets (`pendkit demo` "
                          "writes a GIF)")
    # Gymnasium's passive checker is off: after a reset refused for a bad option it breaks every later
    # step (it expects its first reset to have returned); tests/test_env.py runs check_env on the env instead.
    kwargs.setdefault("disable_env_checker", True)
    return gymnasium.make(ENV_ID, **kwargs)


__all__ = ["ENV_ID", "FIDELITY_PRESETS", "ActionError", "ConfigError", "Fidelity", "PendkitError",
           "RigParams", "SwingUpEnv", "__version__", "make"]
