"""Jobs checked at submission (`make_job`): what a rig would refuse, or should never be sent, is refused in one
line before anything is queued; what passes carries its blob, its servo and its time limit."""

from __future__ import annotations

import math
import zlib

import pytest

from pendkit.adapt.excitation import ADAPT_FREE_STEPS, LOOP_DRIVE_STEPS, LOOP_FREE_STEPS, Excitation
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack, parse
from pendkit.errors import ConfigError
from pendkit.queue.jobs import (
    EXCITATION_STEPS,
    LOOP_EXCITATION_STEPS,
    MAX_UPLOAD_BYTES,
    make_job,
    submit_job,
)
from pendkit.queue.rig_reset import spread_counts
from pendkit.queue.store import QueueStore
from pendkit.rig import RigParams
from tests.queue.runner_rigs import network_blob


def test_a_controller_is_designed_at_submission_for_its_servo():
    spec, blob, servo = make_job("controller", {"controller": "energy"}, None)
    assert parse(blob).kind == "swing-up" and servo == (150, 450)
    assert spec["episodes"] == 10 and spec["episode_steps"] == 500 and spec["control_step_s"] == 0.06
    assert spec["time_limit_s"] >= 10 * 30  # ten 30 s episodes and their resets
    spec, _, servo = make_job("controller", {"controller": "trajopt", "preset": "turnigy-tgy-wp23"}, None)
    assert servo == (200, 400) and spec["servo"] == "turnigy-tgy-wp23"
    _, _, servo = make_job("controller", {"controller": "energy",
                                          "params": {"servo_min_counts": 160, "servo_max_counts": 440}}, None)
    assert servo == (160, 440)


@pytest.mark.parametrize("kind, options, payload, said", [
    ("teleport", {}, None, "unknown job kind"),
    ("controller", {"controller": "lqr"}, None, "controller must be one of"),
    ("controller", {"controller": "energy", "speed": 3}, None, "not speed"),
    ("controller", {"controller": "energy", "episodes": 0}, None, "episodes must be"),
    ("controller", {"controller": "energy", "episodes": 10.5}, None, "episodes must be"),
    ("controller", {"controller": "energy", "episode_steps": 100}, None, "episode_steps must be"),
    ("controller", {"controller": "energy", "time_limit_s": math.inf}, None, "time_limit_s must be"),
    ("controller", {"controller": "energy", "preset": "futaba"}, None, "unknown servo preset"),
    ("controller", {"controller": "energy", "params": {"dowel_colour": 3}}, None, "unknown rig parameters"),
    ("controller", {"controller": "energy", "params": {"servo_range_deg": 400.0}}, None, "servo_range_deg"),
    ("controller", {"controller": "energy"}, b"PKCB", "takes no file"),
    ("blob", {}, None, "needs the blob's bytes"),
    ("blob", {}, b"\0" * (MAX_UPLOAD_BYTES + 1), "more than the queue takes"),
    ("blob", {}, b"PKCB" + b"\0" * 200, "device's checks"),
    ("policy", {"policy": "nobody-trained-me"}, None, "unknown policy"),
    ("excitation", {"episodes": 50}, None, "episodes must be"),
])
def test_what_a_rig_must_not_get_is_refused_in_one_line(kind, options, payload, said):
    with pytest.raises(ConfigError, match=said) as refused:
        make_job(kind, options, payload)
    assert "\n" not in str(refused.value)


def test_a_blob_is_held_to_the_devices_own_checks():
    good = pack(design_swing_up(RigParams(), "energy"))
    spec, blob, servo = make_job("blob", {"episodes": 2}, good)
    assert blob == good and spec["crc"] == zlib.crc32(good) and spec["blob_kind"] == "swing-up"
    assert servo == (150, 450)  # the kit's rig unless the team names the servo it was made for
    damaged = bytearray(good)
    damaged[40] ^= 0xFF
    with pytest.raises(ConfigError, match="CRC"):
        make_job("blob", {}, bytes(damaged))
    with pytest.raises(ConfigError, match="a network blob: the device runs swing-up, policy"):
        make_job("blob", {}, network_blob())


def test_a_blob_for_another_servo_is_refused():
    """A swing-up carries its servo's range: one designed for a 60-degree servo is not run on a 90-degree one."""
    narrow = pack(design_swing_up(RigParams(servo_range_deg=60.0), "energy"))
    with pytest.raises(ConfigError, match="designed for a servo of \\+-60.0 deg"):
        make_job("blob", {"preset": "hitec-d645mw"}, narrow)
    _, _, servo = make_job("blob", {"params": {"servo_range_deg": 60.0}}, narrow)
    assert servo == (150, 450)


def test_a_policy_the_device_cannot_run_is_refused_with_the_reason():
    pytest.importorskip("torch")
    with pytest.raises(ConfigError, match="the device runs r-dqn and r-td3\\+both policies; this is a td3"):
        make_job("policy", {"policy": "td3-realistic"}, None)


def test_a_shipped_device_policy_becomes_its_blob():
    pytest.importorskip("torch")
    spec, blob, servo = make_job("policy", {"policy": "r-dqn-realistic", "episodes": 1}, None)
    assert parse(blob).kind == "policy" and servo == (150, 450) and spec["control_step_s"] == 0.06


def test_an_excitation_job_records_adapts_episodes():
    spec, payload, servo = make_job("excitation", {}, None)
    assert payload is None and servo is None and spec["episodes"] == 6  # pendkit adapt's six
    jump = Excitation(2, 0.9, free_steps=ADAPT_FREE_STEPS)
    assert EXCITATION_STEPS == jump.drive_steps + jump.free_steps  # the queue's copy of adapt's numbers
    assert LOOP_EXCITATION_STEPS == LOOP_DRIVE_STEPS + LOOP_FREE_STEPS


def test_a_job_is_queued_with_its_own_time_limit(tmp_path):
    store = QueueStore(str(tmp_path / "queue.db"))
    store.add_team("a", "token-a")
    job_id = submit_job(store, "a", "controller", {"controller": "energy", "time_limit_s": 120})
    job = store.job(job_id)
    assert job.time_limit_s == 120 and job.servo_range == (150, 450) and parse(job.payload).kind == "swing-up"


def test_stillness_is_read_across_the_encoders_wrap():
    assert spread_counts([1022, 1023, 0, 1, 0]) == 3  # hanging still: the reading flickers across 0
    assert spread_counts([0, 10, 1020]) == 14
