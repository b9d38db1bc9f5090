"""The firmware's loop in Python: commands, limits and safety stops that no command overrides."""

from hypothesis import given, settings
from hypothesis import strategies as st

from pendkit.backend_contract import ServoCommand
from pendkit.device.logic import McuLogic, calibrate_position
from pendkit.rig import RigParams

P = RigParams()


def test_discrete_increment_on_every_acting_tick_until_the_limit():
    mcu = McuLogic(P)
    mcu.reset(440, 0)
    mcu.receive(ServoCommand("discrete", 4), 0)
    assert [mcu.acting_tick(t) for t in (10, 20, 30, 40)] == [444, 448, 450, 450]
    assert "arm_limit" in mcu.flags
    assert mcu.command.increment_counts == 0  # the action ended at the limit


def test_continuous_target_maps_to_counts():
    mcu = McuLogic(P)
    mcu.receive(ServoCommand("continuous", target_unit=-1.0), 0)
    assert mcu.acting_tick(10) == 150
    mcu.receive(ServoCommand("continuous", target_unit=0.5), 20)
    assert mcu.acting_tick(30) == 375


def test_watchdog_stops_the_servo_when_the_host_goes_silent():
    mcu = McuLogic(P)
    mcu.reset(300, 0)
    mcu.receive(ServoCommand("discrete", 2), 0)
    counts = [mcu.acting_tick(t) for t in range(10, 300, 10)]
    stopped_at = counts[int(P.watchdog_timeout_ms // 10)]
    assert "watchdog" in mcu.flags and counts[-1] == stopped_at
    mcu.receive(ServoCommand("discrete", 2), 300)
    assert mcu.acting_tick(310) == stopped_at + 2


def spin_up(mcu, counts_per_tick, ticks=8):
    position = 0
    for k in range(ticks):
        position = (position + counts_per_tick) % 1024
        mcu.streaming_tick(position, 25 * (k + 1))


def command_sequences(max_increment, max_target, max_size):
    """Any mix of discrete increments and continuous targets, including out-of-range ones."""
    discrete = st.builds(ServoCommand, st.just("discrete"), st.integers(-max_increment, max_increment))
    continuous = st.builds(ServoCommand, st.just("continuous"), st.just(0), st.floats(-max_target, max_target))
    return st.lists(st.one_of(discrete, continuous), min_size=1, max_size=max_size)


@settings(max_examples=60, deadline=None)
@given(command_sequences(50, 1, 20))
def test_no_command_sequence_moves_the_servo_while_over_spinning(commands):
    mcu = McuLogic(P)
    mcu.reset(300, 0)
    spin_up(mcu, 60)  # 60 counts per 25 ms = 2.34 rev/s > 2 rev/s
    assert "overspin" in mcu.flags
    for k, command in enumerate(commands):
        mcu.receive(command, 200 + 10 * k)
        assert mcu.acting_tick(200 + 10 * k) == 300


@settings(max_examples=60, deadline=None)
@given(command_sequences(1000, 1e6, 30))
def test_no_command_sequence_leaves_the_arm_range(commands):
    mcu = McuLogic(P)
    for k, command in enumerate(commands):
        mcu.receive(command, 10 * k)
        assert P.servo_min_counts <= mcu.acting_tick(10 * k) <= P.servo_max_counts


def test_over_spin_clears_when_the_pendulum_slows():
    mcu = McuLogic(P)
    spin_up(mcu, 60)
    assert "overspin" in mcu.flags
    for k in range(8):
        mcu.streaming_tick(480, 300 + 25 * k)
    assert "overspin" not in mcu.flags


def test_observation_fields():
    mcu = McuLogic(P)
    mcu.reset(300, 0)
    mcu.streaming_tick(10, 0)
    mcu.receive(ServoCommand("discrete", 2), 0)
    mcu.acting_tick(10)
    mcu.acting_tick(20)
    observation = mcu.streaming_tick(20, 25)
    assert observation.servo_counts == 304
    assert observation.arm_velocity_counts_s == 4 / 0.025
    assert observation.omega_rev_s == (10 / 1024 / 0.025) / P.velocity_mean_window


def test_calibration_offset():
    assert calibrate_position(317, 317) == 0
    assert calibrate_position(316, 317) == 1023
