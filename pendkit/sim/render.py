"""RGB frames of the rig: MuJoCo's offscreen renderer where a GL backend works, else a matplotlib drawing.

Rendering must never crash an episode for lack of OpenGL (students' laptops, CI), so every GL failure
falls back to the drawing, which needs only the arm and pendulum angles.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from pendkit.gl_backend import choose_gl_backend
from pendkit.rig import RigParams

FRAME_WIDTH = 480
FRAME_HEIGHT = 360
_GL_FAILED = False


def mujoco_renderer(model, width: int = FRAME_WIDTH, height: int = FRAME_HEIGHT):
    """A `mujoco.Renderer`, or None (with a warning, once) when no GL backend works here."""
    global _GL_FAILED
    if _GL_FAILED:
        return None
    choose_gl_backend()
    try:
        import mujoco

        renderer = mujoco.Renderer(model, height=height, width=width)
        return renderer
    except Exception as error:  # any GL failure means "draw instead"
        _GL_FAILED = True
        warnings.warn(f"MuJoCo rendering unavailable ({error}); drawing frames with matplotlib instead",
                      RuntimeWarning, stacklevel=2)
        return None


def rig_points_m(params: RigParams, arm_angle_rad: float, pendulum_angle_rad: float) -> np.ndarray:
    """3D points (servo axis, pivot, tip) for an arm angle and a pendulum angle from the bottom."""
    ca, sa = math.cos(arm_angle_rad), math.sin(arm_angle_rad)
    pivot = np.array([params.pivot_radius_m * ca, params.pivot_radius_m * sa, params.pivot_height_m])
    length = params.dowel_length_m
    # The pendulum swings about the arm's axis: (0, L sin(theta), -L cos(theta)) in the arm's frame.
    local_y, local_z = length * math.sin(pendulum_angle_rad), -length * math.cos(pendulum_angle_rad)
    tip = pivot + np.array([-sa * local_y, ca * local_y, local_z])
    return np.stack([np.zeros(3), pivot, tip])


class DrawnFrames:
    """A matplotlib drawing of the rig seen from the front, slightly above; reuses one figure."""

    def __init__(self, params: RigParams, width: int = FRAME_WIDTH, height: int = FRAME_HEIGHT) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.params = params
        self.figure = Figure(figsize=(width / 100, height / 100), dpi=100)
        self.canvas = FigureCanvasAgg(self.figure)
        self.axes = self.figure.add_axes((0, 0, 1, 1))
        self.axes.set_xlim(-0.55, 0.55)
        self.axes.set_ylim(-0.5, 0.5)
        self.axes.set_aspect("equal")
        self.axes.axis("off")
        self.axes.plot([0, 0], [-0.5, -0.02], color="#333333", lw=6)  # stand
        (self.arm_line,) = self.axes.plot([], [], color="#9aa0a6", lw=5, solid_capstyle="round")
        (self.pendulum_line,) = self.axes.plot([], [], color="#d9a15f", lw=3)
        (self.tip_marker,) = self.axes.plot([], [], "o", color="#0072b2", ms=10)
        self.label = self.axes.text(-0.52, 0.38, "", fontsize=9, family="monospace")

    def _project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # Front view from -y, tilted 20 degrees down so the arm's swing shows.
        tilt = math.radians(20)
        return points[:, 0], points[:, 2] * math.cos(tilt) + points[:, 1] * math.sin(tilt)

    def frame(self, arm_angle_rad: float, pendulum_angle_rad: float) -> np.ndarray:
        xs, ys = self._project(rig_points_m(self.params, arm_angle_rad, pendulum_angle_rad))
        self.arm_line.set_data(xs[:2], ys[:2])
        self.pendulum_line.set_data(xs[1:], ys[1:])
        self.tip_marker.set_data(xs[2:], ys[2:])
        upright_deg = math.degrees((pendulum_angle_rad % (2 * math.pi)) - math.pi)
        self.label.set_text(f"arm {math.degrees(arm_angle_rad):6.1f} deg\n"
                            f"pendulum {upright_deg:6.1f} deg from upright")
        self.canvas.draw()
        return np.asarray(self.canvas.buffer_rgba())[:, :, :3].copy()
