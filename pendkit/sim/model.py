"""The MuJoCo twin's model, written from `RigParams` at load time.

Geometry (a rotary, Furuta pendulum): the servo axis is the world z axis; at arm angle 0 the arm points
along +x. The pendulum hinges about the arm's own long axis at `pivot_radius_m` and hangs along -z, so
pendulum angle 0 is hanging and pi is upright. Positive arm angle is counter-clockwise seen from above.

The servo is one actuator: an integrator whose state is the target angle (so a discrete "move at this
rate" command needs no per-substep Python), a proportional-derivative drive clipped at the stall
torque, and back-EMF damping on the joint, which together give a linear torque-speed curve that
tops out at the datasheet's no-load speed. The gear train's reflected rotor inertia is joint armature.

The printed parts' masses sit in simple shapes (hidden, group 3) that the analytic model shares. For
drawing, `build_model(params, assets=...)` adds the printed parts as meshes (the STL files' solids,
`pendkit.cad.twin_meshes.visual_twin_model`: visual only, no mass); physics, training and the virtual rig
compile without them, so none of them touches the CAD.
"""

from __future__ import annotations

import functools
import math

import mujoco

from pendkit.rig import GRAVITY_M_S2, RigParams

ARM_JOINT = "arm"
PENDULUM_JOINT = "pendulum"
SERVO_ACTUATOR = "servo"
SERVO_HEIGHT_M = 0.55  # height of the arm above the floor in drawings; physics does not depend on it

_TEMPLATE = """
<mujoco model="pendkit-furuta">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep_s}" integrator="RK4" gravity="0 0 -{gravity}">
    <flag contact="disable" {energy_flag}/>
  </option>
  <visual><global offwidth="640" offheight="480"/><quality shadowsize="1024"/>
    <headlight ambient=".35 .35 .35" diffuse=".45 .45 .45"/></visual>
  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1=".93 .95 .98" rgb2=".70 .76 .84" width="64" height="64"/>
    <texture name="grid" type="2d" builtin="checker" rgb1=".92 .92 .92" rgb2=".85 .85 .85" width="256" height="256"/>
    <material name="grid" texture="grid" texrepeat="8 8"/>
    <material name="aluminium" rgba=".75 .77 .80 1"/>
    <material name="pine" rgba=".87 .72 .48 1"/>
    <material name="print" rgba=".00 .45 .70 1"/>
    <material name="dark" rgba=".20 .20 .22 1"/>
{mesh_assets}  </asset>
  <worldbody>
    <light pos="0.3 -0.6 1.2" dir="-0.2 0.5 -1"/>
    <geom name="floor" type="plane" size="1 1 0.01" material="grid" pos="0 0 -{servo_height}"/>
    <geom name="stand" type="cylinder" size="0.015 {stand_half}" pos="0 0 -{stand_centre}" material="dark" mass="0"/>
{print_servo_mount}
{print_base_clamp}
    <camera name="front" pos="{cam_x} -1.1 0.15" xyaxes="1 0 0 0 0.2 1"/>
    <camera name="top" pos="{cam_x} 0 1.1" xyaxes="1 0 0 0 1 0"/>
    <body name="arm">
      <joint name="{arm}" type="hinge" axis="0 0 1" range="-{range_rad} {range_rad}" damping="{arm_damping}"
             armature="{armature}"/>
      <geom name="arm_tube" type="box" pos="{arm_half} 0 0" size="{arm_half} {tube_half_w} {tube_half_h}"
            mass="{arm_mass}" material="aluminium"/>
      <geom name="servo_horn" type="cylinder" size="{horn_r} {horn_hh}" pos="0 0 {horn_z}" mass="{horn_mass}"
            material="dark"/>
      <geom name="encoder_mount" type="box" size="{mount_hx} {mount_hy} {mount_half_h}" pos="{pivot_r} 0 {mount_z}"
            mass="{mount_mass}" material="print" group="3"/>
{print_encoder_mount}
      <geom name="encoder" type="cylinder" size="{enc_r} {enc_hl}" pos="{encoder_x} 0 {pivot_z}" zaxis="1 0 0"
            mass="{encoder_mass}" material="dark"/>
      <body name="pendulum" pos="{pivot_r} 0 {pivot_z}">
        <joint name="{pendulum}" type="hinge" axis="1 0 0" damping="{pendulum_damping}"/>
        <geom name="coupler" type="sphere" size="{coupler_r}" mass="{coupler_mass}" material="print" group="3"/>
{print_coupler}
        <geom name="dowel" type="cylinder" fromto="0 0 0 0 0 -{dowel_len}" size="{dowel_r}"
              mass="{dowel_mass}" material="pine"/>
        <geom name="tip_weight" type="cylinder" pos="0 0 -{tip_z}" size="{tip_r} {tip_half_h}"
              mass="{tip_mass}" material="print" group="3"/>
{print_tip_weight}
        <site name="tip" pos="0 0 -{dowel_len}" size="0.004"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <general name="{servo}" joint="{arm}" dyntype="integrator" gaintype="fixed" gainprm="{kp}"
             biastype="affine" biasprm="0 -{kp} -{kv}" actlimited="true" actrange="-{range_rad} {range_rad}"
             forcelimited="true" forcerange="-{stall} {stall}" ctrllimited="true"
             ctrlrange="-{max_rate} {max_rate}"/>
  </actuator>
</mujoco>
"""


PRINTED_PART_NAMES = ("tip_weight", "coupler", "encoder_mount", "servo_mount", "base_clamp")


def _printed_parts_xml(drawn: bool) -> dict[str, str]:
    """The mesh assets and the massless, collision-free geoms that draw the printed parts (or nothing)."""
    if not drawn:
        return {"mesh_assets": "", **{f"print_{name}": "" for name in PRINTED_PART_NAMES}}
    meshes = "".join(f'    <mesh name="{name}" file="{name}.stl" scale=".001 .001 .001"/>\n'
                     for name in PRINTED_PART_NAMES)
    geoms = {f"print_{name}": f'<geom name="{name}_print" type="mesh" mesh="{name}" material="print" mass="0" '
                              'contype="0" conaffinity="0"/>' for name in PRINTED_PART_NAMES}
    return {"mesh_assets": meshes, **geoms}


def model_xml(params: RigParams, *, lock_arm: bool = False, energy: bool = False, drawn_parts: bool = False) -> str:
    """The MJCF text for `params`. `lock_arm` fixes the arm (for analytic checks of the pendulum);
    `drawn_parts` adds the printed parts' meshes (files `<part>.stl`, given as assets when compiled)."""
    stand_half = SERVO_HEIGHT_M / 2 - 0.01
    values = dict(**_printed_parts_xml(drawn_parts),
        timestep_s=params.physics_step_ms / 1000.0, gravity=GRAVITY_M_S2,
        energy_flag='energy="enable"' if energy else "",
        servo_height=SERVO_HEIGHT_M, stand_half=stand_half, stand_centre=stand_half + 0.02,
        cam_x=params.pivot_radius_m / 2,
        arm=ARM_JOINT, pendulum=PENDULUM_JOINT, servo=SERVO_ACTUATOR,
        range_rad=params.servo_range_rad, armature=params.servo_reflected_inertia_kg_m2,
        arm_damping=params.servo_back_emf_damping_n_m_s_per_rad,
        arm_half=params.arm_length_m / 2, tube_half_w=params.arm_tube_width_m / 2,
        tube_half_h=params.arm_tube_height_m / 2, arm_mass=params.arm_mass_kg,
        horn_r=params.horn_radius_m, horn_hh=params.horn_half_height_m,
        horn_z=params.arm_tube_height_m / 2 + params.horn_half_height_m, horn_mass=params.servo_horn_mass_kg,
        mount_hx=params.mount_half_x_m, mount_hy=params.mount_half_y_m, enc_r=params.encoder_radius_m,
        enc_hl=params.encoder_half_length_m,
        pivot_r=params.pivot_radius_m, pivot_z=params.pivot_height_m,
        mount_half_h=params.pivot_height_m / 2, mount_z=params.pivot_height_m / 2,
        mount_mass=params.encoder_mount_mass_kg,
        encoder_x=params.pivot_radius_m - params.encoder_inset_m, encoder_mass=params.encoder_mass_kg,
        pendulum_damping=params.pendulum_damping_n_m_s_per_rad,
        coupler_r=params.coupler_radius_m, coupler_mass=params.coupler_mass_kg,
        dowel_len=params.dowel_length_m, dowel_r=params.dowel_diameter_m / 2, dowel_mass=params.dowel_mass_kg,
        tip_z=params.tip_centre_from_pivot_m, tip_r=params.tip_diameter_m / 2,
        tip_half_h=params.tip_height_m / 2, tip_mass=params.tip_mass_kg,
        kp=params.servo_kp_n_m_per_rad, kv=params.servo_kv_n_m_s_per_rad,
        stall=params.servo_stall_torque_n_m, max_rate=100.0,
    )
    xml = _TEMPLATE.format(**values)
    if lock_arm:
        arm_joint = xml[xml.index(f'<joint name="{ARM_JOINT}"'):]
        xml = xml.replace(arm_joint[:arm_joint.index("/>") + 2], "")
        xml = xml[:xml.index("<actuator>")] + xml[xml.index("</actuator>") + len("</actuator>"):]
    return xml


def build_model(params: RigParams, *, assets: dict[str, bytes] | None = None, lock_arm: bool = False,
                energy: bool = False) -> mujoco.MjModel:
    """Compile the twin for `params` (cached without `assets`: RigParams is frozen and hashable; do not
    mutate the result). `assets`: STL bytes per printed part ("<part>.stl"), to draw them."""
    if assets is None:
        return _physics_model(params, lock_arm, energy)
    xml = model_xml(params, lock_arm=lock_arm, energy=energy, drawn_parts=True)
    return mujoco.MjModel.from_xml_string(xml, assets)


@functools.lru_cache(maxsize=16)
def _physics_model(params: RigParams, lock_arm: bool, energy: bool) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(model_xml(params, lock_arm=lock_arm, energy=energy))


def fresh_model(params: RigParams, **kwargs) -> mujoco.MjModel:
    """An uncached model that callers may modify (tests, system identification)."""
    return mujoco.MjModel.from_xml_string(model_xml(params, **kwargs))


def small_oscillation_period_s(params: RigParams) -> float:
    """Analytic period of small swings with the arm held (compound pendulum, no damping)."""
    return 2 * math.pi / params.pendulum_natural_frequency_rad_s
