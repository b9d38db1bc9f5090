"""Recordings checked before identification (issue 72, part 5): each fault, made by corrupting a healthy twin's
recording, is refused in one line naming the sensor or the clock, and `pendkit adapt` then writes nothing;
healthy recordings (the twin through every classroom network, a virtual rig behind poor WiFi) pass."""

import dataclasses
import json

import numpy as np
import pytest

from pendkit.adapt import recording_checks, session
from pendkit.adapt.excitation import EXCITATION_STREAM, Excitation, Recording, record, schedule
from pendkit.adapt.recording_checks import check_recordings, max_pendulum_speed_rad_s
from pendkit.adapt.replay import trace_from_log
from pendkit.adapt.rigs import configured_prior, twin_rig
from pendkit.errors import RecordingError
from pendkit.rig import RigParams
from pendkit.telemetry.log import LogRecord

HIDDEN = RigParams.preset("mks-x5-hbl550").with_dowel_length(0.34)  # the fastest preset servo, a short pendulum


def recorded(params, network, log_dir, episodes=2, loop_episodes=0):
    env = twin_rig(params, network).make_env(stream=EXCITATION_STREAM, log_dir=str(log_dir),
                                             **Excitation.env_kwargs())
    recordings = [record(env, e, seed=k) for k, e in enumerate(schedule(episodes, loop_episodes))]
    env.close()
    return recordings


@pytest.fixture(scope="module")
def healthy(tmp_path_factory):
    return recorded(HIDDEN, "classroom-wifi", tmp_path_factory.mktemp("logs"))


def with_device(recording, **changes):
    return dataclasses.replace(recording, device=dataclasses.replace(recording.device, **changes))


def stuck(recording):
    """The encoder frozen at its reading at rest: the host's view and the device's trace alike."""
    trace = recording.device
    frozen = trace and dataclasses.replace(trace, pendulum_rad=(trace.pendulum_rad[0],) * len(trace.ms))
    return dataclasses.replace(recording, pendulum_rad=[recording.start_pendulum_rad] * len(recording.actions),
                               pendulum_velocity_rad_s=[0.0] * len(recording.actions), device=frozen)


def with_nan(recording):
    angles = list(recording.pendulum_rad)
    angles[40] = float("nan")
    return dataclasses.replace(recording, pendulum_rad=angles)


def wrapped(recording):
    """The device's angles left wrapped into [0, 2 pi), as an encoder's counts are before unwrapping."""
    return with_device(recording, pendulum_rad=tuple(np.mod(recording.device.pendulum_rad, 2 * np.pi)))


def restarted(recording):
    """The device's clock back to a few ms a second into the episode: a board that browned out and restarted."""
    ms = np.asarray(recording.device.ms)
    ms[100:] = ms[100:] - ms[100] + 3.0
    return with_device(recording, ms=tuple(ms))


def clock_jumps(recording):
    """The device's clock 60 s ahead from a second in, the laptop's arrivals as they were (100% loss, read as a
    network would be)."""
    ms = np.asarray(recording.device.ms)
    ms[100:] += 60_000.0
    return with_device(recording, ms=tuple(ms))


def nothing_arrived(recording):
    return dataclasses.replace(recording, device=None)


FAULTS = {  # corruption, what the refusal must say
    # (an episode's length: 102 steps by hand, 90 as `pendkit adapt` records it)
    "stuck-encoder": (stuck, r"trial 1: the encoder stayed at \d+ counts for all (6\.1|5\.4) s .* is the magnet"),
    "nan-encoder": (with_nan, r"trial 1: the encoder's angle is NaN in 1 of (102|90) readings \(first at step 41"),
    "wrapping-encoder": (wrapped, r"the encoder's angle jumped further than the pendulum can turn .* wrapped round"),
    "clock-backwards": (restarted, r"the device's clock went backwards once .* restarted mid-recording"),
    "clock-jumps": (clock_jumps, r"the device's clock jumped 6\d{4} ms ahead of the laptop's once \(first 0\.99 s"),
    "all-readings-lost": (nothing_arrived, r"no reading of the device reached the laptop .* lost them all"),
}


def test_healthy_recordings_pass_through_every_classroom_network_with_the_loop_episodes(tmp_path):
    for network in ("none", "classroom-wifi", "poor-wifi"):
        check_recordings(recorded(HIDDEN, network, tmp_path / network, loop_episodes=1), HIDDEN)
    slow = RigParams.preset("hitec-d645mw-4v8").with_dowel_length(0.45)
    check_recordings(recorded(slow, "poor-wifi", tmp_path / "slow"), slow)
    env = twin_rig(HIDDEN, "classroom-wifi").make_env(**Excitation.env_kwargs())  # no log: the host's view only
    check_recordings([record(env, e) for e in schedule(2)], HIDDEN, device_clock=False)


@pytest.mark.parametrize("fault", FAULTS)
def test_a_faulty_recording_is_refused_naming_the_sensor_or_the_clock(healthy, fault):
    corrupt, said = FAULTS[fault]
    with pytest.raises(RecordingError, match=said):
        check_recordings([corrupt(healthy[0]), healthy[1]], HIDDEN)
    check_recordings(healthy, HIDDEN)  # the healthy ones, untouched, still pass


def test_a_nan_on_the_devices_clock_names_the_clock_and_the_host_view_alone_is_checked_too(healthy):
    ms = list(healthy[1].device.ms)
    ms[7] = float("nan")
    with pytest.raises(RecordingError, match=r"trial 2: the device's clock is NaN in 1 of \d+ readings"):
        check_recordings([healthy[0], with_device(healthy[1], ms=tuple(ms))], HIDDEN)
    host_only = [dataclasses.replace(r, device=None) for r in healthy]
    check_recordings(host_only, HIDDEN, device_clock=False)
    with pytest.raises(RecordingError, match="the encoder stayed at"):
        check_recordings([stuck(host_only[0])], HIDDEN, device_clock=False)


def test_a_loose_sensors_single_glitch_is_a_jump_no_pendulum_makes(healthy):
    angles = np.asarray(healthy[0].device.pendulum_rad)
    angles[250] += 300 * 2 * np.pi / 1024  # 300 counts off for one reading
    with pytest.raises(RecordingError, match=r"2 times \(first 1\.8\d rad in 10 ms, 2\.50 s in\): .* loose magnet"):
        check_recordings([with_device(healthy[0], pendulum_rad=tuple(angles))], HIDDEN)
    # the bound is physical: far above what the fastest preset servo swings a short pendulum to, far below a wrap
    fastest = np.max(np.abs(np.diff(healthy[0].device.pendulum_rad)) / np.diff(healthy[0].device.ms) * 1000)
    assert 3 * fastest < max_pendulum_speed_rad_s(HIDDEN) < np.pi / 0.01


def test_a_gap_in_which_the_pendulum_could_swing_unseen_names_the_link(healthy):
    trace = healthy[0].device
    keep = [k for k in range(len(trace.ms)) if not 200 <= k < 240]  # 400 ms of readings lost, both clocks alike
    gap = with_device(healthy[0], **{name: tuple(np.asarray(getattr(trace, name))[keep]) for name in
                                     ("ms", "pendulum_rad", "servo_counts", "host_ms")})
    with pytest.raises(RecordingError, match=r"the link lost every reading for 410 ms .* WiFi"):
        check_recordings([gap], HIDDEN)


def test_a_clock_gone_back_in_the_log_is_kept_as_evidence_and_refused():
    """The readings after a restart are not kept in the trace (as before), but the restart is."""
    def reading(t_s, millis, position):
        return LogRecord(t_s, "rx", "pendulum-r/obs/r01", f"S{millis},{position},300,0.0,0.0,0.0")

    records = [reading(0.0, 5000, 0), *(reading(0.01 * k, 5000 + 10 * k, k) for k in range(1, 30)),
               *(reading(0.3 + 0.01 * k, 20 + 10 * k, 30 + k) for k in range(30))]
    trace = trace_from_log(records, 1)
    assert trace.clock_back_ms == ((5290.0, 20.0),) and max(trace.ms) == 5290.0
    assert type(trace).from_dict(json.loads(json.dumps(trace.as_dict()))) == trace
    with pytest.raises(RecordingError, match=r"went backwards once \(first from 5290 ms to 20 ms\)"):
        recording_checks.check_clock_runs_forward(Recording([0.0] * 5, 0.0, 0.0, device=trace), HIDDEN, 1)


def test_a_servo_range_the_status_misreports_is_refused_both_ways(tmp_path):
    narrow = dataclasses.replace(HIDDEN, servo_min_counts=180, servo_max_counts=420)
    recordings = recorded(narrow, "classroom-wifi", tmp_path / "narrow", episodes=1)
    check_recordings(recordings, configured_prior(180, 420))  # what the rig's status says, and does
    with pytest.raises(RecordingError, match=r"status reports servo counts 150\.\.450, but its device applied 192, "
                                             r"300, 408 counts for targets -0\.90, \+0\.00, \+0\.90, which that "
                                             r"range puts at 165, 300, 435: the status misreports"):
        check_recordings(recordings, configured_prior(150, 450))  # a wider range than the device drives
    wide = recorded(HIDDEN, "classroom-wifi", tmp_path / "wide", episodes=1)
    with pytest.raises(RecordingError, match=r"reports servo counts 200\.\.400, but its device applied 165, 300, 435"):
        check_recordings(wide, configured_prior(200, 400))  # a narrower one: the device drove beyond it
    host_only = dataclasses.replace(wide[0], device=None, start_servo_target_rad=1.9)
    with pytest.raises(RecordingError, match=r"but the servo's target read \+109 deg at the start"):
        check_recordings([host_only], configured_prior(200, 400), device_clock=False)


def test_a_servo_that_never_moved_names_the_commands_not_the_encoder(healthy):
    held = with_device(stuck(healthy[0]), servo_counts=(300,) * len(healthy[0].device.ms))
    with pytest.raises(RecordingError, match="the device kept the servo at 300 counts throughout, while targets "
                                             r"-0\.90\.\.\+0\.90 were sent: the commands did not reach it"):
        check_recordings([held], HIDDEN)


@pytest.mark.parametrize("fault", FAULTS)
def test_adapt_refuses_a_faulty_recording_before_writing_anything(tmp_path, monkeypatch, fault):
    corrupt, said = FAULTS[fault]
    real_record = recording_checks.record
    monkeypatch.setattr(recording_checks, "record", lambda env, excitation, seed: corrupt(
        real_record(env, excitation, seed)) if seed == 0 else real_record(env, excitation, seed))
    out = tmp_path / "out"
    config = session.AdaptConfig(episodes=2, excitation_episodes=2, twin_episodes=1, evaluation_episodes=1,
                                 candidates=(), identification_evaluations=30)
    with pytest.raises(RecordingError, match=said):
        session.adapt(twin_rig(HIDDEN, "classroom-wifi"), out, config, say=lambda text: None)
    assert not out.exists()  # no rig.json, policy, blobs, report, nor the recordings


def test_adapt_refuses_a_rig_whose_status_misreports_its_servo_range_and_writes_nothing(tmp_path):
    narrow = dataclasses.replace(HIDDEN, servo_min_counts=180, servo_max_counts=420)
    rig = dataclasses.replace(twin_rig(narrow, "classroom-wifi"), prior=lambda: configured_prior(150, 450))
    (tmp_path / "out").mkdir()  # an --out folder that exists already stays as it was: empty
    with pytest.raises(RecordingError, match="status misreports the servo's range"):
        session.adapt(rig, tmp_path / "out", session.AdaptConfig(episodes=1, excitation_episodes=1, candidates=()),
                      say=lambda text: None)
    assert list((tmp_path / "out").iterdir()) == []


def test_the_command_says_the_refusal_in_one_line_and_leaves_no_folder(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from pendkit.cli import main

    real_record = recording_checks.record
    monkeypatch.setattr(recording_checks, "record", lambda env, excitation, seed: stuck(
        real_record(env, excitation, seed)))
    HIDDEN.save(tmp_path / "rig.json")
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["adapt", "--backend", "sim", "--params", str(tmp_path / "rig.json"),
                                       "--out", str(out), "--episodes", "1"])
    assert result.exit_code == 1 and not out.exists(), result.output
    line = result.output.strip().splitlines()[-1]
    assert "the encoder stayed at" in line and f"nothing written to {out}" in line


@pytest.mark.expensive  # a virtual rig over MQTT in real time: about 25 s
def test_a_virtual_rig_behind_poor_wifi_passes_and_its_stuck_encoder_is_refused(tmp_path):
    from pendkit.adapt.recording_checks import record_checked
    from pendkit.adapt.rigs import mqtt_rig
    from pendkit.link.virtual_rig import LocalRig

    for fault in (None, "stuck"):
        local = LocalRig(impairment="poor-wifi", encoder_fault=fault)
        try:
            rig = mqtt_rig(local.rig, local.url)
            if fault is None:
                recordings, prior, logs = record_checked(rig, schedule(1, 1))
                assert len(recordings) == 2 and logs and prior.servo_min_counts == 150
            else:
                with pytest.raises(RecordingError, match="trial 1: the encoder stayed at 0 counts"):
                    record_checked(rig, schedule(1))
        finally:
            local.stop()
