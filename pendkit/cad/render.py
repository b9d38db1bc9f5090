"""Pictures for the build guide, drawn by MuJoCo's renderer from the CAD solids: the assembled rig's two
ends and the same parts pulled apart along their assembly directions (exploded)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pendkit.cad.assembly import bought_parts, printed_parts, to_stl_bytes
from pendkit.cad.parts import PrintSettings, pivot_mm
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.sim.render import mujoco_renderer

COLOURS = {"printed": ".00 .45 .70 1", "arm_tube": ".75 .77 .80 1", "dowel": ".87 .72 .48 1",
           "table": ".60 .45 .30 1", "other": ".20 .20 .22 1"}
# Where each part moves in the exploded view (mm), along the direction it is fitted in.
EXPLODE_MM = {"base_clamp": (0, 0, -70), "table": (0, 60, -70), "servo_mount": (0, 0, -35), "servo": (0, 0, -10),
              "servo_spline": (0, 0, 0), "servo_horn": (0, 0, 15), "arm_tube": (0, 0, 30),
              "encoder_mount": (-30, 0, 30), "encoder_body": (-70, 0, 60), "encoder_bushing": (-70, 0, 60),
              "encoder_shaft": (-70, 0, 60), "coupler": (25, 0, 60), "dowel": (55, 0, 20), "tip_weight": (55, 0, -30)}
VIEWS = {  # name: (look-at point, distance m, azimuth deg, elevation deg); the point in rig mm
    "servo-end": ((0, 0, -40), 0.38, 135, -20),
    "pendulum-end": ("pivot", 0.16, 125, -20),
    "whole": ((200, 0, -150), 0.85, 120, -15),
}


def scene_xml(names: list[str], offsets_mm: dict[str, tuple[float, float, float]], printed: set[str]) -> str:
    assets, geoms = [], []
    for name in names:
        colour = COLOURS["printed"] if name in printed else COLOURS.get(name, COLOURS["other"])
        dx, dy, dz = (v / 1000 for v in offsets_mm.get(name, (0, 0, 0)))
        assets.append(f'<mesh name="{name}" file="{name}.stl" scale=".001 .001 .001"/>')
        geoms.append(f'<geom type="mesh" mesh="{name}" pos="{dx} {dy} {dz}" rgba="{colour}"/>')
    return (
        '<mujoco><visual><global offwidth="1200" offheight="800"/><quality shadowsize="2048"/></visual>'
        f'<asset><texture type="skybox" builtin="gradient" rgb1="1 1 1" rgb2=".80 .84 .90" width="64" height="64"/>'
        f'{"".join(assets)}</asset><worldbody>'
        '<light pos="0.3 -0.6 1.2" dir="-0.2 0.5 -1" diffuse=".8 .8 .8"/>'
        '<light pos="-0.4 0.6 0.8" dir="0.3 -0.5 -1" diffuse=".4 .4 .4"/>'
        f'{"".join(geoms)}</worldbody></mujoco>')


def render(params: RigParams | None = None, out_dir: str | Path = "docs/img", width: int = 800,
           height: int = 560) -> list[Path]:
    """Write cad-<view>.png (assembled) and cad-<view>-exploded.png for every view; needs a GL backend."""
    import mujoco
    from PIL import Image

    params = params or RigParams()
    printed = printed_parts(params, PrintSettings())
    solids = {**printed, **bought_parts(params)}
    assets = {f"{name}.stl": to_stl_bytes(solid) for name, solid in solids.items()}
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for exploded in (False, True):
        model = mujoco.MjModel.from_xml_string(
            scene_xml(list(solids), EXPLODE_MM if exploded else {}, set(printed)), assets)
        renderer = mujoco_renderer(model, width, height)
        if renderer is None:
            raise ConfigError("no OpenGL backend for MuJoCo's renderer here (set MUJOCO_GL=egl or osmesa)")
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        for view, (target, distance, azimuth, elevation) in VIEWS.items():
            camera = mujoco.MjvCamera()
            point = pivot_mm(params) if target == "pivot" else target
            camera.lookat[:] = np.asarray(point) / 1000
            camera.distance, camera.azimuth, camera.elevation = distance, azimuth, elevation
            renderer.update_scene(data, camera)
            path = out / f"cad-{view}{'-exploded' if exploded else ''}.png"
            Image.fromarray(renderer.render()).save(path)
            written.append(path)
        renderer.close()
    return written
