import math

import pytest

from pendkit.errors import ConfigError
from pendkit.rig import SERVO_PRESETS, RigParams


def test_defaults_are_the_papers_rig():
    p = RigParams()
    assert (p.arm_length_m, p.dowel_length_m, p.tip_mass_kg, p.encoder_counts) == (0.400, 0.400, 0.0095, 1024)
    assert p.servo_name == "Hitec D645MW"
    assert (p.physics_step_ms, p.control_step_ms, p.streaming_period_ms, p.acting_period_ms) == (5, 60, 25, 10)
    assert p.frame_skip == 12
    assert p.overspin_limit_rev_s == 2.0


def test_servo_speed_and_torque_derived_from_the_datasheet():
    p = RigParams()
    assert p.servo_speed_rad_s == pytest.approx(math.radians(60) / 0.20)
    assert p.servo_stall_torque_n_m == pytest.approx(11.3 * 9.81 / 100)
    # back-EMF damping caps the speed at the datasheet's no-load speed under full torque
    assert p.servo_stall_torque_n_m / p.servo_back_emf_damping_n_m_s_per_rad == pytest.approx(p.servo_speed_rad_s)


def test_servo_counts_round_trip_and_clip():
    p = RigParams()
    assert p.servo_counts_to_rad(300) == 0.0
    assert p.servo_counts_to_rad(450) == pytest.approx(math.pi / 2)
    assert p.servo_rad_to_counts(p.servo_counts_to_rad(237)) == 237
    assert p.servo_rad_to_counts(3.0) == 450 and p.servo_rad_to_counts(-3.0) == 150


@pytest.mark.parametrize("changes, words", [
    ({"tip_mass_kg": -0.01}, ["tip_mass_kg", "> 0", "-0.01"]),
    ({"control_step_ms": 62.0}, ["control_step_ms=62.0", "physics_step_ms=5.0"]),
    ({"encoder_offset_counts": 1024}, ["encoder_offset_counts", "[0, 1023]", "1024"]),
    ({"servo_max_counts": 100}, ["servo_max_counts", "100"]),
    ({"filter_coefficient": 1.0}, ["filter_coefficient", "[0.0, 0.999]"]),
    ({"arm_length_m": float("nan")}, ["arm_length_m"]),
])
def test_validation_names_value_and_allowed_range(changes, words):
    with pytest.raises(ConfigError) as error:
        RigParams().replace(**changes)
    for word in words:
        assert word in str(error.value)


def test_presets_exist_and_differ():
    assert set(SERVO_PRESETS) >= {"hitec-d645mw", "turnigy-tgy-wp23", "hitec-hsb-9380th", "mks-x5-hbl550"}
    turnigy = RigParams.preset("turnigy-tgy-wp23")
    assert (turnigy.servo_min_counts, turnigy.servo_max_counts) == (200, 400)
    assert (turnigy.discrete_slow_step_counts, turnigy.discrete_fast_step_counts) == (1, 2)
    with pytest.raises(ConfigError, match="unknown rig preset 'nope'"):
        RigParams.preset("nope")


def test_frozen_and_hashable():
    p = RigParams()
    with pytest.raises(AttributeError):
        p.arm_length_m = 1.0
    assert hash(p) == hash(RigParams())
