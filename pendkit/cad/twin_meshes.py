"""The printed parts as the twin's visual meshes: the same solids the STL files are cut from, placed in the
frame of the MJCF body that carries them (metres there, millimetres here: the MJCF scales by 1/1000).
Only drawing needs them (`visual_twin_model`); the twin's physics compiles without."""

from __future__ import annotations

import functools

from pendkit.cad.assembly import to_stl_bytes
from pendkit.cad.parts import PRINTED_PARTS, PrintSettings, pivot_mm
from pendkit.rig import RigParams
from pendkit.sim.model import build_model

# MJCF body of each printed part: the pendulum's parts move with it, the mount with the arm, the rest stand.
BODY_OF_PART = {"tip_weight": "pendulum", "coupler": "pendulum", "encoder_mount": "arm",
                "servo_mount": "world", "base_clamp": "world"}


@functools.lru_cache(maxsize=16)
def twin_meshes(params: RigParams) -> dict[str, bytes]:
    """STL bytes per printed part, "<name>.stl", in its body's frame."""
    pivot = tuple(-value for value in pivot_mm(params))
    meshes = {}
    for name, make in PRINTED_PARTS.items():
        part = make(params, PrintSettings())
        if BODY_OF_PART[name] == "pendulum":
            part = part.translate(pivot)
        meshes[f"{name}.stl"] = to_stl_bytes(part)
    return meshes


@functools.lru_cache(maxsize=4)
def visual_twin_model(params: RigParams):
    """The twin's model with the printed parts drawn (same bodies and joints as the physics model: copy
    its qpos in to draw a state). Cached; do not mutate."""
    return build_model(params, assets=twin_meshes(params))
