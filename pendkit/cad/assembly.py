"""The assembled rig: printed parts with the bought ones they hold (tube, encoder, shaft, dowel, servo, a
table), a check that nothing overlaps, and STL export of the printed parts. Millimetres."""

from __future__ import annotations

import json
from itertools import combinations
from pathlib import Path

import manifold3d as mf
import numpy as np

from pendkit.cad.parts import (
    COUPLER_INBOARD_MM,
    DEFAULT_PRINT,
    MM,
    PLATE_GAP_MM,
    PLATE_MM,
    PRINTED_PARTS,
    SHAFT_END_MM,
    PrintSettings,
    _box,
    _cylinder,
    _servo_top_mm,
    pivot_mm,
    printed_mass_g,
    servo_footprint_mm,
    table_top,
    tip_weight,
)
from pendkit.rig import RigParams

# Assembly order for the build guide: each printed part's file and what it joins.
ASSEMBLY_ORDER = (
    ("base_clamp", "Clamp base_clamp.stl to the table edge (M6 screw from below)."),
    ("servo_mount", "Drop the servo into servo_mount.stl's window, ears on the deck, four M3 screws; screw the deck "
                    "onto the clamp's top jaw (four M4)."),
    ("encoder_mount", "Slide encoder_mount.stl over the tube's end, pin it with an M3 screw through tube and sleeve; "
                      "bolt the encoder's bushing through its plate."),
    ("coupler", "Push coupler.stl onto the encoder shaft up to the plate gap (0.5 mm), tighten its M3 set screw on "
                "the shaft's flat."),
    ("tip_weight", "Glue tip_weight.stl flush with the dowel's end; glue the dowel into the coupler's socket, "
                   "hanging straight down."),
    ("arm", "Screw the horn to the tube's centre mark and press it on the servo's spline with the arm along "
            "the clamp's length (servo centred)."),
)


def bought_parts(params: RigParams) -> dict[str, mf.Manifold]:
    """The parts the printed ones hold, as simple solids where the twin and the datasheets put them."""
    x, _, z = pivot_mm(params)
    half_w, half_h = params.arm_tube_width_m * MM / 2, params.arm_tube_height_m * MM / 2
    plate_front = x - COUPLER_INBOARD_MM - PLATE_GAP_MM
    encoder_length = 2 * params.encoder_half_length_m * MM
    length, width, offset = servo_footprint_mm(params)
    servo_top = _servo_top_mm(params)
    horn_h = 2 * params.horn_half_height_m * MM
    socket_top = z + params.coupler_radius_m * MM / 2
    return {
        "arm_tube": _box((-15.0, -half_w, -half_h), (params.arm_length_m * MM, half_w, half_h)),
        "servo_horn": _cylinder(params.horn_radius_m * MM, (0, 0, -half_h - horn_h), horn_h, "z"),
        # Where the twin puts it (encoder_inset_m): a mismatch with the mount's plate shows as an overlap.
        "encoder_body": _cylinder(params.encoder_radius_m * MM,
                                  (x - params.encoder_inset_m * MM - encoder_length / 2, 0, z), encoder_length, "x"),
        "encoder_bushing": _cylinder(params.encoder_bushing_diameter_m * MM / 2, (plate_front - PLATE_MM, 0, z),
                                     PLATE_MM + PLATE_GAP_MM / 2, "x"),
        "encoder_shaft": _cylinder(params.encoder_shaft_diameter_m * MM / 2, (plate_front, 0, z),
                                   x - SHAFT_END_MM - plate_front - 0.3, "x"),
        "dowel": _cylinder(params.dowel_diameter_m * MM / 2, (x, 0, socket_top - 0.5),
                           -(socket_top - 0.5 - (z - params.dowel_length_m * MM)), "z"),
        "servo": _box((-offset - length / 2, -width / 2, servo_top - params.servo_body_height_m * MM),
                      (-offset + length / 2, width / 2, servo_top)),
        "servo_spline": _cylinder(3.0, (0, 0, servo_top), -half_h - horn_h - servo_top, "z"),
        "table": table_top(params),
    }


def printed_parts(params: RigParams, settings: PrintSettings = DEFAULT_PRINT) -> dict[str, mf.Manifold]:
    return {name: make(params, settings) for name, make in PRINTED_PARTS.items()}


def overlaps_mm3(params: RigParams, settings: PrintSettings = DEFAULT_PRINT) -> dict[tuple[str, str], float]:
    """Volume (mm^3) shared by any pair of parts with a printed one in it (bought parts among themselves,
    such as the encoder's body, bushing and shaft, are one part)."""
    printed = printed_parts(params, settings)
    solids = {**printed, **bought_parts(params)}
    shared = {}
    for (a, first), (b, second) in combinations(solids.items(), 2):
        if a not in printed and b not in printed:
            continue
        volume = (first ^ second).volume()
        if volume > 0:
            shared[(a, b)] = volume
    return shared


def part_masses_g(params: RigParams, settings: PrintSettings = DEFAULT_PRINT,
                  default_infill: float = 0.4) -> dict[str, float]:
    """Printed mass of each part: the tip weight at the settings' infill, the others at `default_infill`."""
    masses = {}
    for name, make in PRINTED_PARTS.items():
        if name == "tip_weight":
            core = tip_weight(params, settings, settings.wall_mm)
            masses[name] = printed_mass_g(make(params, settings), core, settings)
        else:
            solid = make(params, settings)
            # No exact core for these: walls and skins take roughly surface x wall, the rest is infilled.
            shell = min(solid.volume(), solid.surface_area() * settings.wall_mm)
            masses[name] = (shell + default_infill * (solid.volume() - shell)) * settings.pla_density_g_cm3 / 1000
    return masses


def to_stl_bytes(part: mf.Manifold) -> bytes:
    """Binary STL of a solid (written here: importing trimesh for it costs 0.6 s on every twin's first build)."""
    mesh = part.to_mesh()
    vertices = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    corners = vertices[np.asarray(mesh.tri_verts)]  # (n, 3, 3)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)
    records = np.zeros(len(corners), dtype=[("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    records["normal"], records["corners"] = normals, corners
    header = b"pendkit printed part, millimetres".ljust(80, b" ")
    return header + np.uint32(len(records)).tobytes() + records.tobytes()


def export(out_dir: str | Path, params: RigParams | None = None,
           settings: PrintSettings = DEFAULT_PRINT) -> list[Path]:
    """Write every printed part as STL (mm) and parts.json (volumes, masses, print settings, order)."""
    params = params or RigParams()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    masses = part_masses_g(params, settings)
    summary = {"units": "mm", "settings": settings.__dict__, "parts": {}, "assembly_order": ASSEMBLY_ORDER}
    for name, part in printed_parts(params, settings).items():
        path = out / f"{name}.stl"
        path.write_bytes(to_stl_bytes(part))
        written.append(path)
        box = part.bounding_box()
        summary["parts"][name] = {"file": path.name, "volume_mm3": round(part.volume(), 1),
                                  "printed_mass_g": round(masses[name], 1),
                                  "size_mm": [round(box[i + 3] - box[i], 1) for i in range(3)]}
    summary["filament_per_rig_g"] = round(sum(masses.values()), 1)
    (out / "parts.json").write_text(json.dumps(summary, indent=1))
    return [*written, out / "parts.json"]
