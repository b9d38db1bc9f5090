"""Lab 03's identification feeds the twin: a slower servo's step log gives back its speed, the saved
parameters load in later labs (run by hand only), and bad files are refused."""

import pytest

from pendkit.control.sysid import identify_servo_steps
from pendkit.errors import ConfigError
from pendkit.labs.identified_rig import lab_rig
from pendkit.rig import RigParams
from pendkit.sim.lab_readings import servo_step_readings
from pendkit.sim.servo_fit import match_servo_speed


@pytest.mark.parametrize("s_per_60deg", [0.14, 0.26, 0.4])
def test_the_twin_fitted_to_a_step_log_has_the_servos_speed(s_per_60deg):
    rig = RigParams().replace(servo_speed_s_per_60deg=s_per_60deg)  # the servo on the bench
    log = servo_step_readings(params=rig)
    measured = identify_servo_steps(log.times_s, log.commanded_rad, log.arm_rad).slew_rate_rad_s
    fitted = match_servo_speed(measured)
    assert fitted.servo_speed_s_per_60deg == pytest.approx(s_per_60deg, rel=0.02)


def test_an_impossible_slew_is_refused():
    with pytest.raises(ConfigError, match="outside what a hobby servo"):
        match_servo_speed(500.0)
    with pytest.raises(ConfigError, match="positive"):
        match_servo_speed(float("nan"))


def test_saved_parameters_come_back_and_feed_a_lab_run_by_hand_only(tmp_path, monkeypatch, capsys):
    path = tmp_path / "my_rig.json"
    mine = RigParams().replace(servo_speed_s_per_60deg=0.27, tip_mass_kg=0.012)
    mine.save(path)
    assert RigParams.load(path) == mine
    monkeypatch.setenv("PENDKIT_MODE", "interactive")
    assert lab_rig(path) == mine and "your rig from lab 03" in capsys.readouterr().out
    monkeypatch.setenv("PENDKIT_MODE", "ci")
    assert lab_rig(path) == RigParams() and "ci mode" in capsys.readouterr().out


def test_a_bad_parameters_file_says_what_is_wrong(tmp_path):
    path = tmp_path / "my_rig.json"
    path.write_text('{"servo_speed_s_per_60deg": 0.2, "servo_sped": 1}')
    with pytest.raises(ConfigError, match="unknown rig parameters \\['servo_sped'\\]"):
        RigParams.load(path)
    path.write_text("{not json")
    with pytest.raises(ConfigError, match="cannot read"):
        RigParams.load(path)
