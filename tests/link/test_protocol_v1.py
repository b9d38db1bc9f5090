"""The authors' v1 firmware for real: the kit drives a v1 rig (streaming started, single letters, no
heartbeat, the preset's counts range), and a v2 host is ignored by one, as the real firmware would."""

import pytest

import pendkit
from pendkit.link.driver import RigLinkError
from pendkit.link.virtual_rig import VirtualRig, VirtualRigGroup
from pendkit.rig import RigParams

TURNIGY = RigParams.preset("turnigy-tgy-wp23")  # counts 200..400, as the authors' device uses


def test_the_kit_drives_a_rig_with_the_authors_firmware(broker_url):
    rig = VirtualRig("r01", broker_url, params=TURNIGY, protocol=1)
    with VirtualRigGroup([rig]):
        env = pendkit.make(backend="rig", rig="r01", broker=broker_url, params=TURNIGY, protocol="v1",
                           rig_options={"reset_stop_s": 0.3})
        try:
            observation, _ = env.reset(seed=0)
            arm = [env.step(4)[0][1] for _ in range(10)]  # right fast
            backend = env.unwrapped.backend
            assert arm[-1] > arm[0] + 0.3  # the arm moved: v1 letters were understood
            assert rig.rejected_commands == 0  # no frame, no heartbeat, no `n` ever reached it
            assert backend.link.counters.malformed == 0 and backend.link.newest.received.version == 1
            assert rig.device.scheduler.logic.servo_counts <= 400  # the preset's range, not 150..450
        finally:
            env.close()


def test_a_v2_host_gets_nothing_from_a_v1_rig_and_says_so(broker_url):
    rig = VirtualRig("r02", broker_url, params=TURNIGY, protocol=1)
    with VirtualRigGroup([rig]):
        env = pendkit.make(backend="rig", rig="r02", broker=broker_url, params=TURNIGY,
                           rig_options={"reset_stop_s": 0.2, "observation_timeout_s": 0.5})
        try:
            with pytest.raises(RigLinkError, match="no observation from rig r02"):
                env.reset(seed=0)  # every framed command is unknown to v1 firmware: it never streams
            assert rig.rejected_commands >= 5
        finally:
            env.close()


def test_a_v1_device_has_no_watchdog_so_the_host_is_the_safety():
    from pendkit.device.scheduler import DeviceScheduler

    v1, v2 = DeviceScheduler(TURNIGY, protocol=1), DeviceScheduler(TURNIGY, protocol=2)
    servo = {}
    for name, device in (("v1", v1), ("v2", v2)):
        device.receive("x", 0)
        device.receive("f", 0)
        servo[name] = [device.logic.acting_tick(t) for t in range(10, 400, 10)]
    assert "watchdog" in v2.logic.flags and "watchdog" not in v1.logic.flags
    assert servo["v1"][-1] > servo["v2"][-1]  # v1 keeps moving while the host is silent; v2 holds


@pytest.mark.parametrize("kwargs", [dict(protocol="v3"), dict(protocol="v1")])  # v1 needs a rig
def test_protocol_is_checked(kwargs):
    with pytest.raises(pendkit.ConfigError, match="protocol"):
        pendkit.make(**kwargs)


def test_a_host_with_another_servo_range_than_the_device_is_refused(broker_url):
    with VirtualRigGroup([VirtualRig("r03", broker_url, params=TURNIGY)]):  # built for 200..400
        env = pendkit.make(backend="rig", rig="r03", broker=broker_url, rig_options={"reset_stop_s": 0.2})
        try:
            with pytest.raises(pendkit.ConfigError, match="200..400.*150..450"):
                env.reset(seed=0)
        finally:
            env.close()
