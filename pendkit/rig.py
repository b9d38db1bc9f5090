"""`RigParams`: the one source of truth for the rig's dimensions, masses, servo, encoder and timing.

Everything else (the MuJoCo twin, the linear model, the firmware constants) is derived from it.
Defaults are the paper's rig (Hitec D645MW servo); `RigParams.preset(name)` gives the other servos.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
from dataclasses import dataclass
from typing import Any

from pendkit.errors import ConfigError
from pendkit.safe_write import write_text

GRAVITY_M_S2 = 9.81
KG_CM_TO_N_M = GRAVITY_M_S2 / 100.0
# Allowed ranges of fields a device blob carries too (pendkit.device.physical_ranges reads them)
PENDULUM_DAMPING_RANGE_N_M_S_PER_RAD = (0.0, 1.0)
SERVO_RANGE_RANGE_DEG = (1.0, 180.0)


@dataclass(frozen=True)
class RigParams:
    """Physical and timing parameters of one rig. Lengths in metres, masses in kilograms."""

    # --- arm: aluminium tube, turned about the vertical axis by the servo ---
    arm_length_m: float = 0.400
    arm_tube_width_m: float = 0.020
    arm_tube_height_m: float = 0.010
    arm_mass_kg: float = 0.125
    servo_horn_mass_kg: float = 0.004
    # The authors' MJCF puts the encoder axis 425 mm from the servo axis (the mount overhangs the
    # 400 mm tube) and 18 mm above it; we follow the model, which was fitted to the real rig.
    pivot_radius_m: float = 0.425
    pivot_height_m: float = 0.018
    encoder_mount_mass_kg: float = 0.010
    encoder_mass_kg: float = 0.017
    # Small parts' shapes (the twin's MJCF and the analytic model both read them)
    horn_radius_m: float = 0.012
    horn_half_height_m: float = 0.002
    mount_half_x_m: float = 0.006
    mount_half_y_m: float = 0.012
    encoder_radius_m: float = 0.011
    encoder_half_length_m: float = 0.006
    # Encoder body centre, inboard of the pivot along the arm: behind the printed mount's 3 mm plate, with
    # the coupler's 7 mm of shaft engagement in front of it (pendkit/cad/parts.py draws them).
    encoder_inset_m: float = 0.0215
    encoder_shaft_diameter_m: float = 0.00635   # EMS-22A: 1/4 inch shaft
    encoder_bushing_diameter_m: float = 0.0095  # 3/8-32 threaded bushing through the mount's plate

    # --- pendulum: pine dowel with a printed tip weight, hanging from the encoder shaft ---
    coupler_mass_kg: float = 0.015
    dowel_length_m: float = 0.400
    dowel_diameter_m: float = 0.008
    dowel_mass_kg: float = 0.011
    # rig-facts: 9.5 g weighed; the authors' MJCF rounds to 9 g. We keep the weighed value.
    tip_mass_kg: float = 0.0095
    tip_diameter_m: float = 0.040
    tip_height_m: float = 0.012
    coupler_radius_m: float = 0.010
    pendulum_damping_n_m_s_per_rad: float = 0.0015

    # --- encoder: Bourns EMS-22A, absolute ---
    encoder_counts: int = 1024
    encoder_offset_counts: int = 0

    # --- servo (defaults: Hitec D645MW on the 6 V channel) ---
    servo_name: str = "Hitec D645MW"
    # Body of a standard-size servo (the printed mount's window and screw holes), mm-accurate for the D645MW
    servo_body_length_m: float = 0.0405
    servo_body_width_m: float = 0.0200
    servo_body_height_m: float = 0.0370
    servo_ear_hole_spacing_m: float = 0.0495
    servo_speed_s_per_60deg: float = 0.20
    servo_stall_torque_kg_cm: float = 11.3
    servo_range_deg: float = 90.0
    # Assumed: error at which the servo's internal controller gives full torque, and the damping ratio
    # of its position loop. Hobby servos do not publish these; lab 03 identifies them from step responses.
    servo_full_torque_error_deg: float = 5.0
    servo_damping_ratio: float = 0.7
    # Assumed: rotor inertia reflected through the gear train (about 1.5e-7 kg m^2 x a 200:1 ratio^2).
    servo_reflected_inertia_kg_m2: float = 0.006
    # PCA9685 at 50 Hz: 4096 counts per 20 ms. The D645MW shares the Hitec pulse range (150..450).
    pwm_period_ms: float = 20.0
    pwm_resolution_counts: int = 4096
    servo_min_counts: int = 150
    servo_max_counts: int = 450
    discrete_slow_step_counts: int = 2
    discrete_fast_step_counts: int = 4

    # --- timing ---
    physics_step_ms: float = 5.0
    control_step_ms: float = 60.0
    streaming_period_ms: float = 25.0
    acting_period_ms: float = 10.0
    # The paper averages the last 3 velocities; the authors' firmware buffer holds 4. We follow the firmware.
    velocity_mean_window: int = 4

    # --- continuous action filter a_t = c*a_{t-1} + (1-c)*u_t; paper's best 0.85 (firmware default 0.9) ---
    filter_coefficient: float = 0.85

    # --- safety (enforced on the device and in the twin's firmware logic) ---
    overspin_limit_rev_s: float = 2.0
    watchdog_timeout_ms: float = 150.0

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            _check_type(self, field)
            value = getattr(self, field.name)
            if field.name.endswith(("_m", "_kg", "_ms", "_deg", "_s_per_60deg", "_kg_cm")) and not value > 0:
                raise ConfigError(f"{field.name} must be > 0, got {value!r}")
            if isinstance(value, float) and not math.isfinite(value):
                raise ConfigError(f"{field.name} must be finite, got {value!r}")
        _check_range("pendulum_damping_n_m_s_per_rad", self.pendulum_damping_n_m_s_per_rad,
                     *PENDULUM_DAMPING_RANGE_N_M_S_PER_RAD)
        _check_range("encoder_counts", self.encoder_counts, 2, 1 << 16)
        _check_range("encoder_offset_counts", self.encoder_offset_counts, 0, self.encoder_counts - 1)
        _check_range("servo_range_deg", self.servo_range_deg, *SERVO_RANGE_RANGE_DEG)
        _check_range("servo_damping_ratio", self.servo_damping_ratio, 0.0, 5.0)
        _check_range("servo_reflected_inertia_kg_m2", self.servo_reflected_inertia_kg_m2, 0.0, 1.0)
        _check_range("servo_min_counts", self.servo_min_counts, 0, self.pwm_resolution_counts - 1)
        _check_range("servo_max_counts", self.servo_max_counts, self.servo_min_counts + 1,
                     self.pwm_resolution_counts - 1)
        _check_range("discrete_slow_step_counts", self.discrete_slow_step_counts, 1, self.servo_span_counts)
        _check_range("discrete_fast_step_counts", self.discrete_fast_step_counts,
                     self.discrete_slow_step_counts, self.servo_span_counts)
        _check_range("velocity_mean_window", self.velocity_mean_window, 1, 16)  # the protocol's n<1..16>
        _check_range("filter_coefficient", self.filter_coefficient, 0.0, 0.999)
        _check_range("overspin_limit_rev_s", self.overspin_limit_rev_s, 0.1, 50.0)
        for name in ("control_step_ms", "streaming_period_ms", "acting_period_ms", "pwm_period_ms"):
            _check_multiple(name, getattr(self, name), self.physics_step_ms)

    # --- derived quantities (derive, don't repeat; cached: frozen dataclasses keep a __dict__) ---
    @functools.cached_property
    def frame_skip(self) -> int:
        """Physics steps per control step (12 for the paper's 60 ms / 5 ms)."""
        return round(self.control_step_ms / self.physics_step_ms)

    @functools.cached_property
    def servo_range_rad(self) -> float:
        return math.radians(self.servo_range_deg)

    @functools.cached_property
    def servo_span_counts(self) -> int:
        return self.servo_max_counts - self.servo_min_counts

    @functools.cached_property
    def servo_rad_per_count(self) -> float:
        return 2 * self.servo_range_rad / self.servo_span_counts

    @functools.cached_property
    def servo_speed_rad_s(self) -> float:
        """No-load slew rate from the datasheet's seconds per 60 degrees."""
        return math.radians(60.0) / self.servo_speed_s_per_60deg

    @functools.cached_property
    def servo_stall_torque_n_m(self) -> float:
        return self.servo_stall_torque_kg_cm * KG_CM_TO_N_M

    @functools.cached_property
    def servo_back_emf_damping_n_m_s_per_rad(self) -> float:
        """Linear torque-speed curve: torque falls from stall to zero at the datasheet's no-load speed.

        So the servo never drives the arm faster than its rating; an outside torque (the swinging
        pendulum) can drag it faster by torque / damping, as on the real rig.
        """
        return self.servo_stall_torque_n_m / self.servo_speed_rad_s

    @functools.cached_property
    def servo_kp_n_m_per_rad(self) -> float:
        return self.servo_stall_torque_n_m / math.radians(self.servo_full_torque_error_deg)

    @functools.cached_property
    def servo_kv_n_m_s_per_rad(self) -> float:
        """Derivative gain giving the loop its damping ratio, on top of back-EMF damping."""
        inertia = self.arm_inertia_kg_m2 + self.servo_reflected_inertia_kg_m2
        wanted = 2 * self.servo_damping_ratio * math.sqrt(self.servo_kp_n_m_per_rad * inertia)
        return max(0.0, wanted - self.servo_back_emf_damping_n_m_s_per_rad)

    @property
    def pivot_point_masses_kg(self) -> float:
        """Masses riding at the pivot with the arm: encoder, its mount."""
        return self.encoder_mount_mass_kg + self.encoder_mass_kg

    @property
    def pendulum_mass_kg(self) -> float:
        return self.coupler_mass_kg + self.dowel_mass_kg + self.tip_mass_kg

    @property
    def tip_centre_from_pivot_m(self) -> float:
        """The tip weight sits on the dowel's end, its far face flush with it."""
        return self.dowel_length_m - self.tip_height_m / 2

    @property
    def pendulum_com_from_pivot_m(self) -> float:
        moment = self.dowel_mass_kg * self.dowel_length_m / 2 + self.tip_mass_kg * self.tip_centre_from_pivot_m
        return moment / self.pendulum_mass_kg

    @functools.cached_property
    def pendulum_inertia_about_pivot_kg_m2(self) -> float:
        """Compound-pendulum inertia about the encoder axis: dowel rod + tip cylinder + coupler sphere."""
        dowel_radius = self.dowel_diameter_m / 2
        dowel = self.dowel_mass_kg * (self.dowel_length_m**2 / 3 + dowel_radius**2 / 4)
        tip_radius = self.tip_diameter_m / 2
        tip = self.tip_mass_kg * ((3 * tip_radius**2 + self.tip_height_m**2) / 12
                                  + self.tip_centre_from_pivot_m**2)
        coupler = self.coupler_mass_kg * 0.4 * self.coupler_radius_m**2
        return dowel + tip + coupler

    @functools.cached_property
    def pendulum_natural_frequency_rad_s(self) -> float:
        """Small-oscillation frequency with the arm held: sqrt(m g d / I)."""
        return math.sqrt(self.pendulum_mass_kg * GRAVITY_M_S2 * self.pendulum_com_from_pivot_m
                         / self.pendulum_inertia_about_pivot_kg_m2)

    @functools.cached_property
    def pendulum_long_axis_inertia_kg_m2(self) -> float:
        """The pendulum's inertia about its own long axis (it turns with the arm when hanging)."""
        return (self.dowel_mass_kg * (self.dowel_diameter_m / 2) ** 2 / 2
                + self.tip_mass_kg * (self.tip_diameter_m / 2) ** 2 / 2
                + self.coupler_mass_kg * 0.4 * self.coupler_radius_m**2)

    @functools.cached_property
    def arm_inertia_kg_m2(self) -> float:
        """Inertia about the servo axis of everything the servo turns (pendulum hanging), part by part as
        the twin's MJCF builds them; the gear train's reflected inertia is not included."""
        r = self.pivot_radius_m
        arm = self.arm_mass_kg * (self.arm_length_m**2 / 3 + self.arm_tube_width_m**2 / 12)
        horn = self.servo_horn_mass_kg * self.horn_radius_m**2 / 2
        mount = self.encoder_mount_mass_kg * ((2 * self.mount_half_x_m) ** 2 + (2 * self.mount_half_y_m) ** 2) / 12 \
            + self.encoder_mount_mass_kg * r**2
        encoder = self.encoder_mass_kg * (3 * self.encoder_radius_m**2 + (2 * self.encoder_half_length_m) ** 2) / 12 \
            + self.encoder_mass_kg * (r - self.encoder_inset_m) ** 2
        return arm + horn + mount + encoder + self.pendulum_mass_kg * r**2 + self.pendulum_long_axis_inertia_kg_m2

    @functools.cached_property
    def servo_centre_counts(self) -> float:
        return (self.servo_min_counts + self.servo_max_counts) / 2

    def servo_counts_to_rad(self, counts: float) -> float:
        """PCA9685 counts -> commanded arm angle (0 at the centre of the range)."""
        return (counts - self.servo_centre_counts) * self.servo_rad_per_count

    def servo_rad_to_counts(self, angle_rad: float) -> int:
        """Commanded arm angle -> the nearest PCA9685 count inside the servo's range."""
        counts = round(self.servo_centre_counts + angle_rad / self.servo_rad_per_count)
        return min(max(counts, self.servo_min_counts), self.servo_max_counts)

    def replace(self, **changes: Any) -> RigParams:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def preset(cls, name: str) -> RigParams:
        """Parameters for a named servo preset; see `SERVO_PRESETS`."""
        try:
            return cls(**SERVO_PRESETS[name])
        except KeyError:
            raise ConfigError(f"unknown rig preset {name!r}; choose one of {sorted(SERVO_PRESETS)}") from None

    def with_dowel_length(self, length_m: float) -> RigParams:
        """This rig with its dowel cut (or replaced) to `length_m` from the same stock: its mass follows."""
        return dataclasses.replace(self, dowel_length_m=length_m,
                                   dowel_mass_kg=self.dowel_mass_kg * length_m / self.dowel_length_m)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def save(self, path) -> None:
        """Write these parameters as JSON (e.g. a rig's identified values, for the twin and later labs), whole
        or not at all, never through a link planted at `path` (`pendkit.safe_write`)."""
        import json

        write_text(path, json.dumps(self.to_dict(), indent=1) + "\n")

    @classmethod
    def load(cls, path) -> RigParams:
        """Parameters saved by `save`; fields it lacks keep their defaults, unknown ones are refused."""
        import json
        from pathlib import Path

        try:
            values = json.loads(Path(path).read_text())
        except (OSError, ValueError) as error:
            raise ConfigError(f"cannot read rig parameters from {path}: {error}") from None
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(values) - known) if isinstance(values, dict) else ["(not a JSON object)"]
        if unknown:
            raise ConfigError(f"{path}: unknown rig parameters {unknown}")
        return cls(**values)


def _check_type(params: RigParams, field: dataclasses.Field) -> None:
    """Each field as its declared type (a rig file is JSON: 1024.0 is taken as 1024, 930.5 counts, a string or
    null where a number belongs are refused by name)."""
    value = getattr(params, field.name)
    if field.type == "str":
        if not isinstance(value, str):
            raise ConfigError(f"{field.name} must be text, got {value!r}")
        return
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ConfigError(f"{field.name} must be a number, got {value!r}")
    if field.type == "int":
        if not float(value).is_integer():
            raise ConfigError(f"{field.name} must be a whole number, got {value!r}")
        object.__setattr__(params, field.name, int(value))
    else:
        object.__setattr__(params, field.name, float(value))


# Counts and increments for the Turnigy and the HSB-9380TH are the authors' settings (rig-facts.md).
# Speed and torque for the alternatives are approximate datasheet figures: measure your own servo.
# A faster, less lagged stream the firmware can be asked for (`u10`, `n2`; docs/protocol.md): the rate is
# centred 10 ms back instead of 50 ms, and coarser (0.3 rad/s per count instead of 0.06).
FAST_STREAM: dict[str, Any] = {"streaming_period_ms": 10.0, "velocity_mean_window": 2}

SERVO_PRESETS: dict[str, dict[str, Any]] = {
    "hitec-d645mw": {},
    "hitec-d645mw-4v8": {"servo_name": "Hitec D645MW @4.8 V", "servo_speed_s_per_60deg": 0.28,
                         "servo_stall_torque_kg_cm": 8.3},
    "turnigy-tgy-wp23": {"servo_name": "Turnigy TGY-WP23 (oscillates, wears fast)",
                         "servo_speed_s_per_60deg": 0.16, "servo_stall_torque_kg_cm": 6.0,
                         "servo_min_counts": 200, "servo_max_counts": 400,
                         "discrete_slow_step_counts": 1, "discrete_fast_step_counts": 2},
    "hitec-hsb-9380th": {"servo_name": "Hitec HSB-9380TH (too stiff: oscillates)",
                         "servo_speed_s_per_60deg": 0.17, "servo_stall_torque_kg_cm": 25.5,
                         "servo_full_torque_error_deg": 1.0, "servo_damping_ratio": 0.2},
    "mks-x5-hbl550": {"servo_name": "MKS X5 HBL550", "servo_speed_s_per_60deg": 0.12,
                      "servo_stall_torque_kg_cm": 10.0},
}


def _check_range(name: str, value: float, low: float, high: float) -> None:
    if not low <= value <= high:
        raise ConfigError(f"{name} must be in [{low}, {high}], got {value!r}")


def _check_multiple(name: str, value_ms: float, step_ms: float) -> None:
    ratio = value_ms / step_ms
    if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
        raise ConfigError(
            f"{name}={value_ms} ms is not a whole multiple of physics_step_ms={step_ms} ms; "
            f"use e.g. {max(1, round(ratio)) * step_ms} ms")
