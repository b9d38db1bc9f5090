"""The rig's printed parts as parametric solids (manifold3d CSG), every dimension from `RigParams` plus the
printer's clearances in `PrintSettings`. Millimetres throughout (what slicers expect).

Frames: each part is drawn where it sits on the rig, in the arm's frame at arm angle 0 (x along the arm
from the servo axis, z up, the tube's axis at z = 0); the pendulum's parts hang straight down. The
assembly (pendkit/cad/assembly.py) therefore needs no transforms, and the twin can place the meshes at
the same coordinates.

Why manifold3d and not build123d/CadQuery: its wheels are ~3 MB against ~240 MB
for build123d with OpenCascade (measured with `pip download` here), which matters on a student's laptop;
it has exact booleans and volumes, which is all these parts need. It cannot write STEP.
"""

from __future__ import annotations

from dataclasses import dataclass

import manifold3d as mf

from pendkit.errors import ConfigError
from pendkit.rig import RigParams

SEGMENTS = 128  # facets per circle: a cylinder's volume within 0.05 % of pi r^2 h
MM = 1000.0


@dataclass(frozen=True)
class PrintSettings:
    """FDM print settings the parts are designed for (PLA, 0.4 mm nozzle)."""

    bore_clearance_mm: float = 0.2       # per side on holes a dowel or shaft slides into
    wall_mm: float = 1.2                 # perimeters, and top/bottom skins
    infill: float = 0.30                 # the tip weight's infill, chosen for its 9.5 g
    pla_density_g_cm3: float = 1.24

    def __post_init__(self) -> None:
        if not (0 <= self.bore_clearance_mm <= 1 and 0.4 <= self.wall_mm <= 5 and 0 <= self.infill <= 1
                and 0.5 <= self.pla_density_g_cm3 <= 3):
            raise ConfigError(f"print settings out of range: {self}")


DEFAULT_PRINT = PrintSettings()


def _cylinder(radius: float, start: tuple[float, float, float], length: float, axis: str) -> mf.Manifold:
    """A cylinder of `radius` from `start` along +axis ("x", "y", "z") for `length` (negative: -axis)."""
    body = mf.Manifold.cylinder(abs(length), radius, radius, SEGMENTS)
    if length < 0:
        body = body.translate((0, 0, length))
    if axis == "x":
        body = body.rotate((0, 90, 0))
    elif axis == "y":
        body = body.rotate((-90, 0, 0))
    return body.translate(start)


def _box(low: tuple[float, float, float], high: tuple[float, float, float]) -> mf.Manifold:
    size = tuple(h - lo for lo, h in zip(low, high))
    if min(size) <= 0:
        raise ConfigError(f"empty box {low} -> {high}")
    return mf.Manifold.cube(size).translate(low)


def pivot_mm(params: RigParams) -> tuple[float, float, float]:
    return params.pivot_radius_m * MM, 0.0, params.pivot_height_m * MM


# The coupler spans the pivot from 12 mm inboard (shaft side) to 6 mm outboard; the shaft goes in to 5 mm
# short of the pivot, leaving a wall before the dowel's socket.
COUPLER_INBOARD_MM, COUPLER_OUTBOARD_MM, SHAFT_END_MM = 12.0, 6.0, 5.0
PLATE_MM, PLATE_GAP_MM = 3.0, 0.5  # the mount's plate, and its gap to the coupler
SADDLE_LENGTH_MM = 25.0


def tip_weight(params: RigParams, settings: PrintSettings = PrintSettings(), inset_mm: float = 0.0) -> mf.Manifold:
    """A disc on the dowel's end, its centre `tip_centre_from_pivot_m` below the pivot, with a through
    bore for the dowel. `inset_mm` > 0 gives the part shrunk by that much (its infilled core)."""
    x, _, z = pivot_mm(params)
    radius = params.tip_diameter_m * MM / 2 - inset_mm
    height = params.tip_height_m * MM - 2 * inset_mm
    bore = params.dowel_diameter_m * MM / 2 + settings.bore_clearance_mm + inset_mm
    centre = z - params.tip_centre_from_pivot_m * MM
    disc = _cylinder(radius, (x, 0, centre - height / 2), height, "z")
    return disc - _cylinder(bore, (x, 0, centre - height), 2 * height, "z")


def coupler(params: RigParams, settings: PrintSettings = PrintSettings()) -> mf.Manifold:
    """A hub on the encoder's shaft holding the dowel: shaft bore from the inboard end, the dowel's
    socket down through the bottom at the pivot, an M3 set-screw hole (2.5 mm tap) onto the shaft."""
    x, _, z = pivot_mm(params)
    radius = params.coupler_radius_m * MM
    hub = _cylinder(radius, (x - COUPLER_INBOARD_MM, 0, z), COUPLER_INBOARD_MM + COUPLER_OUTBOARD_MM, "x")
    shaft = _cylinder(params.encoder_shaft_diameter_m * MM / 2 + settings.bore_clearance_mm,
                      (x - COUPLER_INBOARD_MM - 1, 0, z), COUPLER_INBOARD_MM - SHAFT_END_MM + 1, "x")
    socket_r = params.dowel_diameter_m * MM / 2 + settings.bore_clearance_mm
    socket = _cylinder(socket_r, (x, 0, z + radius / 2), -(radius * 1.5 + 1), "z")
    screw = _cylinder(1.25, (x - (COUPLER_INBOARD_MM + SHAFT_END_MM) / 2, 0, z), radius + 1, "z")
    return hub - shaft - socket - screw


def encoder_mount(params: RigParams, settings: PrintSettings = PrintSettings()) -> mf.Manifold:
    """A sleeve over the tube's end and a plate the encoder's bushing bolts through, the encoder body
    behind it: the plate's face is where `encoder_inset_m` puts the body's front."""
    x, _, z = pivot_mm(params)
    c = settings.bore_clearance_mm
    half_w, half_h = params.arm_tube_width_m * MM / 2, params.arm_tube_height_m * MM / 2
    tube_end = params.arm_length_m * MM
    plate_front = x - COUPLER_INBOARD_MM - PLATE_GAP_MM
    wall = 2.0
    width = max(half_w + c + wall, params.encoder_radius_m * MM + 2)
    encoder_bottom = z - params.encoder_radius_m * MM
    saddle = _box((tube_end - SADDLE_LENGTH_MM, -width, -half_h - c - wall),
                  (plate_front, width, min(half_h + c + wall, encoder_bottom)))
    slot = _box((tube_end - SADDLE_LENGTH_MM - 1, -half_w - c, -half_h - c), (tube_end + c, half_w + c, half_h + c))
    plate = _box((plate_front - PLATE_MM, -width, -half_h - c - wall),
                 (plate_front, width, z + params.encoder_radius_m * MM + 3))
    bushing = _cylinder(params.encoder_bushing_diameter_m * MM / 2 + c, (plate_front - PLATE_MM - 1, 0, z),
                        PLATE_MM + 2, "x")
    screws = [_cylinder(1.7, (tube_end - SADDLE_LENGTH_MM / 2, 0, -20), 40, "z")]  # M3 through tube and sleeve
    mount = saddle + plate - slot - bushing
    for screw in screws:
        mount -= screw
    return mount


def servo_mount(params: RigParams, settings: PrintSettings = PrintSettings()) -> mf.Manifold:
    """A deck under the arm with a window the servo drops into, hanging by its ears (two screws each side);
    the servo's output shaft on the arm's axis."""
    c = settings.bore_clearance_mm
    length, width, offset = servo_footprint_mm(params)
    top = _servo_top_mm(params)
    deck = _box((-offset - length / 2 - 12, -width / 2 - 10, top - 5), (-offset + length / 2 + 12, width / 2 + 10, top))
    window = _box((-offset - length / 2 - c, -width / 2 - c, top - 6),
                  (-offset + length / 2 + c, width / 2 + c, top + 1))
    mount = deck - window
    for side in (-1, 1):
        for y in (-5.0, 5.0):
            mount -= _cylinder(1.7, (-offset + side * params.servo_ear_hole_spacing_m * MM / 2, y, top - 6), 7, "z")
    for corner_x in (-offset - length / 2 - 7, -offset + length / 2 + 7):
        for y in (-width / 2 - 5, width / 2 + 5):
            mount -= _cylinder(2.2, (corner_x, y, top - 6), 7, "z")  # M4 into the base clamp
    return mount


TABLE_EDGE_Y_MM, CLAMP_DEPTH_MM = 15.0, 70.0  # the table's edge behind the servo; the clamp's reach


def base_clamp(params: RigParams, settings: PrintSettings = PrintSettings(), table_mm: float = 40.0) -> mf.Manifold:
    """A C-clamp for a table edge up to `table_mm` thick. Its top jaw carries the servo mount (M4 holes
    matching) with a window the servo hangs through in front of the table's edge; the bottom jaw takes
    an M6 clamping screw."""
    length, width, offset = servo_footprint_mm(params)
    top = _servo_top_mm(params) - 5  # under the servo mount's deck
    x0, x1 = -offset - length / 2 - 12, -offset + length / 2 + 12
    y0 = -width / 2 - 10
    jaw = 8.0
    floor = top - 2 * jaw - table_mm
    clamp = (_box((x0, y0, top - jaw), (x1, CLAMP_DEPTH_MM, top))
             + _box((x0, CLAMP_DEPTH_MM - 10, floor), (x1, CLAMP_DEPTH_MM, top))
             + _box((x0, TABLE_EDGE_Y_MM, floor), (x1, CLAMP_DEPTH_MM, floor + jaw)))
    clamp -= _box((-offset - length / 2 - 1, -width / 2 - 1, top - jaw - 1),
                  (-offset + length / 2 + 1, width / 2 + 1, top + 1))
    for corner_x in (-offset - length / 2 - 7, -offset + length / 2 + 7):
        for y in (-width / 2 - 5, width / 2 + 5):
            clamp -= _cylinder(1.7, (corner_x, y, top - jaw - 1), jaw + 2, "z")  # M4 tapping
    clamp -= _cylinder(3.25, ((x0 + x1) / 2, (TABLE_EDGE_Y_MM + CLAMP_DEPTH_MM - 10) / 2, floor - 1), jaw + 2, "z")
    return clamp


def table_top(params: RigParams, table_mm: float = 40.0) -> mf.Manifold:
    """The table the clamp grips (for the assembly check): its edge at TABLE_EDGE_Y_MM."""
    top = _servo_top_mm(params) - 5 - 8.0
    return _box((-100, TABLE_EDGE_Y_MM, top - table_mm), (100, CLAMP_DEPTH_MM - 10, top))


def servo_footprint_mm(params: RigParams) -> tuple[float, float, float]:
    """(body length, body width, how far the body's centre sits from the output shaft along -x)."""
    length, width = params.servo_body_length_m * MM, params.servo_body_width_m * MM
    return length, width, length / 2 - width / 2  # the output shaft sits near one end of the body


def _servo_top_mm(params: RigParams) -> float:
    """Top of the servo's body: below the tube, the horn and a 6 mm spline boss."""
    return -params.arm_tube_height_m * MM / 2 - 2 * params.horn_half_height_m * MM - 6.0


PRINTED_PARTS = {
    "tip_weight": tip_weight,
    "coupler": coupler,
    "encoder_mount": encoder_mount,
    "servo_mount": servo_mount,
    "base_clamp": base_clamp,
}


def printed_mass_g(part: mf.Manifold, core: mf.Manifold | None, settings: PrintSettings) -> float:
    """Mass of a print: solid walls and skins, the core at the infill fraction (core None: solid)."""
    density = settings.pla_density_g_cm3 / 1000  # g per mm^3
    if core is None:
        return part.volume() * density
    return (part.volume() - core.volume() * (1 - settings.infill)) * density


def tip_weight_mass_g(params: RigParams, settings: PrintSettings = PrintSettings()) -> float:
    return printed_mass_g(tip_weight(params, settings), tip_weight(params, settings, settings.wall_mm), settings)


def bore_diameter_mm(params: RigParams, settings: PrintSettings = PrintSettings()) -> float:
    """The coupler's dowel socket measured on the solid: the empty part of a thin probe disc, a little wider
    than the dowel, across the socket halfway down."""
    x, _, z = pivot_mm(params)
    probe = _cylinder(params.dowel_diameter_m * MM / 2 + 1.5, (x, 0, z - params.coupler_radius_m * MM / 2), 0.1, "z")
    hole = probe - coupler(params, settings)
    if hole.is_empty():
        return 0.0
    low, high = hole.bounding_box()[:3], hole.bounding_box()[3:]
    return high[1] - low[1]
