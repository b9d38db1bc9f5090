"""The physical range of every rig parameter a device blob carries (an observer's model, policy layout 2),
drawn from the kit's rig (`RigParams`, the one source of truth) with generous margins: a factor of MARGIN
either way for inertias, torques and gains (any classroom Furuta pendulum, any hobby servo), from zero where a
rig may have none (damping, a servo's derivative gain, the coupling), and RigParams' own allowed range where it
has one. A blob outside them (a pendulum of 1e-38 kg m^2, say) is refused by the parser, before a device's
observer divides by it; the firmware's parser reads the same table (written into rig_constants.h by
`pendkit.firmware_constants`).

Each field is also held to rigid-body sense: the model's mass matrix must be positive at every pendulum angle
(arm inertia x pendulum inertia > coupling^2, arm inertia + pendulum inertia > the long-axis inertia). A swing-up
blob's model terms (each a ratio of two of the model's, or the pendulum's natural frequency) get the ranges
their parts' ranges allow.
"""

from __future__ import annotations

import math

import numpy as np

from pendkit.rig import GRAVITY_M_S2, PENDULUM_DAMPING_RANGE_N_M_S_PER_RAD, SERVO_RANGE_RANGE_DEG, RigParams

MARGIN = 100.0
FLOAT32_SLACK = 1e-6  # a bound's own value survives its rounding to float32 in a blob
MAY_BE_ZERO = ("coupling_kg_m2", "arm_damping_n_m_s_per_rad", "servo_kv_n_m_s_per_rad")
UNITS = {"kg_m2": "kg m^2", "n_m": "N m", "n_m_s_per_rad": "N m s/rad", "n_m_per_rad": "N m/rad", "rad": "rad"}


def nominal_model(params: RigParams | None = None) -> dict[str, float]:
    """The observer model's terms for `params` (default the kit's rig), in MODEL_FIELDS' order, as
    `pendkit.control.model.FurutaModel.from_rig` makes them (a test holds the two together)."""
    p = params or RigParams()
    mass, com = p.pendulum_mass_kg, p.pendulum_com_from_pivot_m
    return {"arm_inertia_kg_m2": p.arm_inertia_kg_m2 + p.servo_reflected_inertia_kg_m2,
            "pendulum_inertia_kg_m2": p.pendulum_inertia_about_pivot_kg_m2,
            "pendulum_long_axis_inertia_kg_m2": p.pendulum_long_axis_inertia_kg_m2,
            "coupling_kg_m2": mass * p.pivot_radius_m * com,
            "gravity_torque_n_m": mass * GRAVITY_M_S2 * com,
            "pendulum_damping_n_m_s_per_rad": p.pendulum_damping_n_m_s_per_rad,
            "arm_damping_n_m_s_per_rad": p.servo_back_emf_damping_n_m_s_per_rad,
            "servo_kp_n_m_per_rad": p.servo_kp_n_m_per_rad,
            "servo_kv_n_m_s_per_rad": p.servo_kv_n_m_s_per_rad,
            "servo_stall_torque_n_m": p.servo_stall_torque_n_m,
            "servo_range_rad": p.servo_range_rad}


def _model_ranges() -> dict[str, tuple[float, float]]:
    ranges = {}
    for name, value in nominal_model().items():
        low, high = (0.0 if name in MAY_BE_ZERO else value / MARGIN), value * MARGIN
        ranges[name] = (low, high)
    ranges["pendulum_damping_n_m_s_per_rad"] = PENDULUM_DAMPING_RANGE_N_M_S_PER_RAD
    ranges["servo_range_rad"] = tuple(math.radians(d) for d in SERVO_RANGE_RANGE_DEG)
    return {name: (low * (1 - FLOAT32_SLACK), high * (1 + FLOAT32_SLACK)) for name, (low, high) in ranges.items()}


MODEL_RANGES = _model_ranges()  # field -> (lowest, highest), both allowed


def unit_of(name: str) -> str:
    return next((unit for suffix, unit in UNITS.items() if name.endswith("_" + suffix)), "")


def model_problem(model) -> str | None:
    """What is physically wrong with one observer model (values in MODEL_FIELDS' order), or None."""
    values = dict(zip(MODEL_RANGES, (float(v) for v in np.asarray(model, dtype=np.float64))))
    for name, value in values.items():
        low, high = MODEL_RANGES[name]
        if not low <= value <= high:
            return (f"{name} = {value:.3g} is outside its physical range {low:.3g}..{high:.3g} {unit_of(name)} "
                    f"(the kit's rig's {nominal_model()[name]:.3g}, within a factor of {MARGIN:g})")
    arm, pendulum = values["arm_inertia_kg_m2"], values["pendulum_inertia_kg_m2"]
    coupling, long_axis = values["coupling_kg_m2"], values["pendulum_long_axis_inertia_kg_m2"]
    if not arm * pendulum > coupling * coupling:
        return (f"arm_inertia_kg_m2 x pendulum_inertia_kg_m2 = {arm * pendulum:.3g} does not exceed coupling_kg_m2^2 = "
                f"{coupling * coupling:.3g}: no rigid body has that mass matrix")
    if not arm + pendulum > long_axis:
        return (f"pendulum_long_axis_inertia_kg_m2 = {long_axis:.3g} exceeds the arm's and pendulum's inertias "
                f"together: no rigid body has that mass matrix")
    return None


# A swing-up blob's model terms per unit of inertia (pendkit.deploy.swingup_design): numerator / denominator
PER_INERTIA = {"servo_kp_per_inertia": ("servo_kp_n_m_per_rad", "arm_inertia_kg_m2"),
               "servo_kv_per_inertia": ("servo_kv_n_m_s_per_rad", "arm_inertia_kg_m2"),
               "arm_damping_per_inertia": ("arm_damping_n_m_s_per_rad", "arm_inertia_kg_m2"),
               "stall_per_inertia": ("servo_stall_torque_n_m", "arm_inertia_kg_m2"),
               "coupling_per_inertia": ("coupling_kg_m2", "pendulum_inertia_kg_m2"),
               "pendulum_damping_per_inertia": ("pendulum_damping_n_m_s_per_rad", "pendulum_inertia_kg_m2")}


def _swing_up_ranges() -> dict[str, tuple[float, float]]:
    ranges = {name: (MODEL_RANGES[top][0] / MODEL_RANGES[bottom][1], MODEL_RANGES[top][1] / MODEL_RANGES[bottom][0])
              for name, (top, bottom) in PER_INERTIA.items()}
    gravity, pendulum = MODEL_RANGES["gravity_torque_n_m"], MODEL_RANGES["pendulum_inertia_kg_m2"]
    ranges["natural_frequency_rad_s"] = (math.sqrt(gravity[0] / pendulum[1]), math.sqrt(gravity[1] / pendulum[0]))
    ranges["servo_range_rad"] = MODEL_RANGES["servo_range_rad"]
    return ranges


SWING_UP_RANGES = _swing_up_ranges()  # a swing-up blob's scalar -> (lowest, highest), both allowed


def swing_up_problem(values: dict[str, float]) -> str | None:
    """What is physically wrong with a swing-up blob's scalars (by name), or None."""
    for name, (low, high) in SWING_UP_RANGES.items():
        if not low <= values[name] <= high:
            return (f"{name} = {values[name]:.3g} is outside its physical range {low:.3g}..{high:.3g} (what the "
                    f"ranges of its model's terms allow)")
    return None
