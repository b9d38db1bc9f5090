"""A rig that does not answer on a working broker: a typo in its id, a rig that went offline, and a host
user's own rig are told apart in the one line the env raises."""

import pytest

import pendkit
from pendkit.link.driver import RigLinkError
from pendkit.link.virtual_rig import VirtualRig, VirtualRigGroup

QUICK = {"reset_stop_s": 0.3, "observation_timeout_s": 0.5}


def reset_fails(url: str, rig: str) -> str:
    env = pendkit.make(backend="rig", rig=rig, broker=url, rig_options=QUICK)
    try:
        with pytest.raises(RigLinkError) as raised:
            env.reset(seed=0)
    finally:
        env.close()
    return str(raised.value)


def test_a_typo_in_the_rig_id_names_the_rigs_that_are_there(broker_url):
    with VirtualRigGroup([VirtualRig("r01", broker_url), VirtualRig("r02", broker_url)]):
        message = reset_fails(broker_url, "r10")
    assert "no rig 'r10' has ever reported" in message and "r01, r02" in message, message
    assert "\n" not in message


def test_a_rig_that_stopped_is_named_offline(broker_url):
    group = VirtualRigGroup([VirtualRig("r03", broker_url)])
    group.start()
    group.stop()  # publishes its retained {"online": false}, as the broker does for a rig that lost power
    message = reset_fails(broker_url, "r03")
    assert "rig r03 is offline" in message and "last will" in message, message


def test_a_host_user_sees_only_its_own_rig_so_the_kit_does_not_guess(classroom):
    credentials = classroom.credentials()
    env = pendkit.make(backend="rig", rig="r02", broker=classroom.url,  # r02 is not running
                       rig_options={**QUICK, "username": "host-r02", "password": credentials["host-r02"]})
    with VirtualRigGroup([VirtualRig("r01", classroom.url, username="r01", password=credentials["r01"])]):
        try:
            with pytest.raises(RigLinkError) as raised:
                env.reset(seed=0)
        finally:
            env.close()
    message = str(raised.value)
    assert "ever reported" not in message and "rig r02 did not answer" in message, message
