"""Which OpenGL backend MuJoCo uses: chosen before MuJoCo is first imported (it reads MUJOCO_GL then)."""

from __future__ import annotations

import os
import sys


def choose_gl_backend() -> str | None:
    """Pick a headless GL backend on Linux without a display (EGL), unless the user chose one."""
    if "MUJOCO_GL" not in os.environ and sys.platform.startswith("linux") and not os.environ.get("DISPLAY"):
        os.environ["MUJOCO_GL"] = "egl"
        os.environ.setdefault("PYOPENGL_PLATFORM", "egl")
    return os.environ.get("MUJOCO_GL")
