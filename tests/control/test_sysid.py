"""System identification recovers what the twin was built with."""

import math

import numpy as np
import pytest

import pendkit
from pendkit.control.model import FurutaModel
from pendkit.control.sysid import identify_free_swing, identify_servo_steps
from pendkit.encoder import counts_to_rad
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.sim.lab_readings import free_swing_readings, servo_step_readings
from pendkit.telemetry.log import readings_from_log


def hanging_mode(params):
    poles = np.linalg.eigvals(np.asarray(FurutaModel.from_rig(params).linearise("hanging").A))
    swing = min(poles, key=lambda p: abs(abs(p) - params.pendulum_natural_frequency_rad_s))
    return abs(swing), -swing.real / abs(swing)


def test_free_swing_from_the_realistic_twins_own_log(tmp_path):
    params = RigParams()
    env = pendkit.make(fidelity="realistic", log_dir=str(tmp_path))
    env.reset(seed=0, options={"start": "rest", "pendulum_angle_rad": 0.5})
    for _ in range(300):
        env.step(0)
    env.close()
    readings = readings_from_log(tmp_path / "episode-0001.jsonl")
    assert readings.malformed == 0 and len(readings.millis) > 500
    fit = identify_free_swing(readings.millis / 1000, counts_to_rad(readings.position_counts))
    omega, zeta = hanging_mode(params)
    assert abs(fit.natural_frequency_rad_s - omega) < max(3 * fit.natural_frequency_se, 0.01 * omega)
    assert fit.damping_ratio == pytest.approx(zeta, rel=0.2)
    assert fit.cycles >= 5


def test_free_swing_with_the_arm_locked_matches_the_compound_pendulum():
    params = RigParams()
    readings = free_swing_readings(period_ms=5.0, duration_s=8.0, start_velocity_rad_s=2.0)
    fit = identify_free_swing(readings.times_ms / 1000, counts_to_rad(readings.raw_counts))
    assert fit.natural_frequency_rad_s == pytest.approx(params.pendulum_natural_frequency_rad_s, rel=0.005)
    zeta = params.pendulum_damping_n_m_s_per_rad / (2 * params.pendulum_inertia_about_pivot_kg_m2
                                                   * params.pendulum_natural_frequency_rad_s)
    assert fit.damping_ratio == pytest.approx(zeta, rel=0.1)


def test_heavier_damping_is_identified_as_heavier():
    light = free_swing_readings(5.0, 8.0, 4.0, params=RigParams())
    heavy = free_swing_readings(5.0, 8.0, 4.0, params=RigParams().replace(pendulum_damping_n_m_s_per_rad=0.003))
    fit_light = identify_free_swing(light.times_ms / 1000, counts_to_rad(light.raw_counts))
    fit_heavy = identify_free_swing(heavy.times_ms / 1000, counts_to_rad(heavy.raw_counts))
    assert fit_heavy.damping_ratio > 2 * fit_light.damping_ratio


def test_servo_slew_and_lag_from_step_responses():
    for preset in ("hitec-d645mw", "hitec-d645mw-4v8"):
        params = RigParams.preset(preset)
        readings = servo_step_readings(params=params)
        fit = identify_servo_steps(readings.times_s, readings.commanded_rad, readings.arm_rad)
        assert fit.steps == 3  # 0 -> 0.6 -> -0.6 -> 0.2: jumps of 0.6, 1.2 and 0.8 rad
        assert 0.6 * params.servo_speed_rad_s < fit.slew_rate_rad_s <= params.servo_speed_rad_s
        assert 0.0 < fit.lag_s < 0.1


def test_bad_inputs_say_what_is_wrong():
    t = np.linspace(0, 1, 50)
    with pytest.raises(ConfigError, match="over the top"):
        identify_free_swing(t, np.linspace(0, 6 * math.pi, 50))
    with pytest.raises(ConfigError, match="at least 3 full cycles"):
        identify_free_swing(t, 0.01 * np.sin(5 * t))
    with pytest.raises(ConfigError, match="no complete command steps"):
        identify_servo_steps(t, np.zeros(50), np.zeros(50))
