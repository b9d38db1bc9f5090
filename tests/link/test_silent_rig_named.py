"""A rig that does not answer on a working broker: a typo in its id, a rig that went offline, and a host
user's own rig are told apart in the one line the env raises."""

import pytest

import pendkit
from pendkit.link.driver import RigLinkError
from pendkit.link.virtual_rig import VirtualRig, VirtualRigGroup
from tests.system_needs import needs

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


def test_login_mistakes_are_told_apart(classroom, tmp_path):
    """No password at all, a CA given for the plain port, the hashed file or the table as a password file,
    another kind of file as credentials: each named as what it is."""
    from click.testing import CliRunner

    from pendkit.cli import main
    from pendkit.link.driver import RigLink

    with pytest.raises(RigLinkError, match="no password was given"):
        RigLink("r01", classroom.url, username="host-r01").connect(timeout_s=1.0)
    paths = classroom.paths
    for wrong in (paths["passwords"], paths["credentials"]):
        result = CliRunner().invoke(main, ["rigs", "--broker", classroom.url, "--username", "instructor",
                                           "--password-file", str(wrong)])
        assert result.exit_code == 2 and "not one password: use broker/logins/USER.txt" in result.output
    result = CliRunner().invoke(main, ["virtual-rig", "--rig", "r01", "--broker", classroom.url,
                                       "--credentials", str(paths["passwords"])])
    assert result.exit_code != 0 and "is not the credentials file broker-config writes" in result.output
    own = CliRunner().invoke(main, ["rigs", "--broker", classroom.url, "--username", "host-r01", "--password-file",
                                    str(paths["logins"] / "host-r01.txt"), "--expect", "r02"])
    assert "not seen by user host-r01, which reads only rig r01" in own.output, own.output


@needs("openssl")
def test_a_ca_for_the_plain_port_is_named(broker_url, tmp_path):
    from pendkit.link.driver import RigLink
    from pendkit.link.tls import make_classroom_ca

    ca = make_classroom_ca(tmp_path)["ca"]  # a real CA, given for a broker's plain port
    with pytest.raises(RigLinkError, match="--tls-ca turns TLS on: drop --tls-ca for this plain port"):
        RigLink("r01", broker_url, tls_ca=str(ca)).connect(timeout_s=1.0)
