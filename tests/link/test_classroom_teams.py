"""Two teams on a real Mosquitto with the generated classroom config: each attack on the other team's rig
fails, while each team's own deploy, eval and adaptation link work with its credentials."""

import contextlib
import os
import subprocess
import time

import paho.mqtt.client as mqtt
import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.cli.broker_login import BrokerLogin
from pendkit.link.broker import MosquittoBroker, mosquitto_binary, write_classroom_config
from pendkit.link.driver import RigLink
from pendkit.link.virtual_rig import VirtualRig, VirtualRigGroup
from tests.link.test_rig_link import wait_for
from tests.system_needs import needs

pytestmark = needs("mosquitto")


@pytest.fixture
def room(tmp_path):
    with MosquittoBroker(tmp_path / "room", rigs=["r01", "r02"]) as broker:
        credentials = broker.credentials()
        rigs = [VirtualRig(rig, broker.url, username=rig, password=credentials[rig]) for rig in ("r01", "r02")]
        with VirtualRigGroup(rigs):
            yield broker, credentials, {rig.rig: rig for rig in rigs}


def raw_client(broker, username, password, client_id):
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=client_id)
    client.username_pw_set(username, password)
    client.connect("127.0.0.1", broker.port)
    client.loop_start()
    return client


def test_a_team_cannot_knock_another_teams_rig_off_the_broker(room):
    broker, credentials, rigs = room
    statuses = []
    watcher = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="w")
    watcher.username_pw_set("instructor", credentials["instructor"])
    watcher.on_message = lambda client, userdata, message: statuses.append(message.payload)
    watcher.connect("127.0.0.1", broker.port)
    watcher.subscribe("pendulum-r/status/r02")
    watcher.loop_start()
    assert wait_for(lambda: statuses)
    its_own_id = rigs["r02"].client._client_id.decode()  # as a sniffer or the docs would tell an attacker
    for stolen_id in (its_own_id, "pendkit-r02", "r02"):  # and the firmware's id, and the rig's username
        attacker = raw_client(broker, "host-r01", credentials["host-r01"], stolen_id)
        time.sleep(0.5)
        attacker.loop_stop()
        attacker.disconnect()
    time.sleep(0.3)
    watcher.loop_stop()
    watcher.disconnect()
    assert not [s for s in statuses if b'"online": false' in s], "r02 was knocked off: its last will was sent"
    assert rigs["r02"].client.is_connected()


def test_a_retained_command_never_moves_a_rig_at_its_next_boot(room, tmp_path):
    broker, credentials, rigs = room
    host = raw_client(broker, "host-r02", credentials["host-r02"], "x")
    host.publish("pendulum-r/act/r02", "g", retain=True).wait_for_publish()  # "right fast", left on the broker
    host.loop_stop()
    host.disconnect()
    rebooted = VirtualRig("r02", broker.url, username="r02", password=credentials["r02"])
    with VirtualRigGroup([rebooted]):
        start = rebooted.device.mcu.servo_counts
        time.sleep(0.6)
        assert rebooted.device.mcu.servo_counts == start and rebooted.commands_received == 0


@pytest.mark.expensive  # the full tier: real-time rig runs
def test_each_team_deploys_and_evaluates_its_own_rig_and_not_the_other(room, tmp_path):
    broker, credentials, rigs = room
    own = ["--rig", "r02", "--broker", broker.url, "--username", "host-r02"]
    env = {"PENDKIT_MQTT_PASSWORD": credentials["host-r02"]}  # the password from the environment
    deployed = CliRunner().invoke(main, ["deploy", *own, "--controller", "energy", "--seconds", "1"], env=env)
    assert deployed.exit_code == 0, deployed.output
    assert "uploaded" in deployed.output and credentials["host-r02"] not in deployed.output
    assert rigs["r02"].device.mcu.onboard.blobs_accepted == 1
    other = CliRunner().invoke(main, ["deploy", "--rig", "r01", "--broker", broker.url, "--username", "host-r02",
                                      "--controller", "energy", "--seconds", "1"], env=env)
    assert other.exit_code != 0 and rigs["r01"].device.mcu.onboard.blobs_accepted == 0
    run = tmp_path / "run"
    trained = CliRunner().invoke(main, ["train", "--episodes", "1", "--max-steps", "20", "--out", str(run), "--quiet"])
    assert trained.exit_code == 0, trained.output
    evaluated = CliRunner().invoke(main, ["eval", str(run), "--backend", "rig", *own, "--episodes", "1"], env=env)
    assert evaluated.exit_code == 0, evaluated.output
    assert evaluated.output.splitlines()[-1] == "solved=0/1 median_upright_s=-"


def test_adaptation_reads_the_rig_with_the_teams_login(room):
    from pendkit.adapt.rigs import mqtt_rig

    broker, credentials, rigs = room
    rig = mqtt_rig("r02", broker.url, BrokerLogin("host-r02", credentials["host-r02"]))
    assert rig.prior().servo_min_counts == rigs["r02"].device.mcu.params.servo_min_counts


def test_the_instructor_may_command_any_rig(room):
    broker, credentials, rigs = room
    instructor = RigLink("r01", broker.url, username="instructor", password=credentials["instructor"])
    instructor.connect()
    before = rigs["r01"].device.mcu.servo_counts
    instructor.publish("g")
    assert wait_for(lambda: rigs["r01"].device.mcu.servo_counts > before)
    instructor.close()


def test_broker_config_adds_rigs_without_new_passwords_and_refuses_reserved_names(tmp_path):
    from pendkit.errors import ConfigError
    from pendkit.link.broker import read_credentials

    write_classroom_config(["r01"], tmp_path)
    first = read_credentials(tmp_path / "credentials.csv")
    write_classroom_config(["r01", "r02"], tmp_path)
    second = read_credentials(tmp_path / "credentials.csv")
    assert {user: second[user] for user in first} == first and {"r02", "host-r02"} <= set(second)
    with pytest.raises(ConfigError, match="keeps for itself"):
        write_classroom_config(["instructor"], tmp_path / "other")
    acl = (tmp_path / "acl").read_text()
    assert "topic write pendulum-r/ctl/r02" in acl and "topic read pendulum-r/ctl/r02" in acl
    assert "use_username_as_clientid true" in (tmp_path / "mosquitto.conf").read_text()


@contextlib.contextmanager
def classroom_mosquitto(folder, rigs, host="127.0.0.1", **options):
    """Mosquitto with `write_classroom_config`'s files (TLS listener included), on `host`; yields the paths and
    the two ports, and stops it after."""
    from pendkit.link.broker import free_port, wait_for_port

    port, tls_port = free_port(), free_port()
    paths = write_classroom_config(rigs, folder, port, host, tls_port=tls_port, **options)
    if os.geteuid() == 0:  # as MosquittoBroker does for tests: mosquitto cannot enter pytest's private folders
        with paths["conf"].open("a") as conf:
            conf.write("user root\n")
    process = subprocess.Popen([mosquitto_binary(), "-c", str(paths["conf"])], stdout=subprocess.DEVNULL,
                               stderr=subprocess.PIPE)
    try:
        assert wait_for_port(host, tls_port)
        yield paths, port, tls_port
    finally:
        process.kill()
        process.wait()


@needs("openssl")
def test_the_generated_tls_listener_takes_a_team_with_the_classroom_ca(tmp_path):
    from pendkit.link.broker import read_credentials
    from pendkit.link.driver import RigLinkError

    with classroom_mosquitto(tmp_path, ["r01"]) as (paths, _, tls_port):
        password = read_credentials(paths["credentials"])["host-r01"]
        link = RigLink("r01", f"mqtts://127.0.0.1:{tls_port}", "host-r01", password, str(paths["ca"]))
        link.connect(timeout_s=5)
        link.close()
        with pytest.raises(RigLinkError):  # without the classroom CA the broker is not trusted
            RigLink("r01", f"mqtts://127.0.0.1:{tls_port}", "host-r01", password).connect(timeout_s=2)


@needs("openssl")
def test_secrets_are_private_and_passwords_hashed_in_mosquittos_format(tmp_path):
    import stat

    from pendkit.link.broker import read_credentials
    from pendkit.link.secret_files import mosquitto_password_check

    paths = write_classroom_config(["r01"], tmp_path, tls_port=8883, addresses=["127.0.0.2"])
    for name in ("passwords", "credentials", "key", "ca_key"):
        mode = stat.S_IMODE(paths[name].stat().st_mode)
        assert mode & 0o007 == 0 and mode & 0o070 in (0, 0o040), (name, oct(mode))  # at most the broker's group
    hashes = dict(line.split(":", 1) for line in paths["passwords"].read_text().splitlines())
    for user, password in read_credentials(paths["credentials"]).items():
        assert hashes[user].startswith("$7$") and mosquitto_password_check(password, hashes[user])
        assert password not in paths["passwords"].read_text()


@needs("openssl")
def test_a_new_address_reissues_the_server_certificate_from_the_same_ca(tmp_path):
    from pendkit.errors import ConfigError

    write_classroom_config(["r01"], tmp_path, tls_port=8883)
    ca = (tmp_path / "ca.crt").read_bytes()
    assert "127.0.0.2" not in (tmp_path / "server-names.txt").read_text().split()
    write_classroom_config(["r01"], tmp_path, tls_port=8883, addresses=["127.0.0.2", "pi-room4.local"])
    assert (tmp_path / "ca.crt").read_bytes() == ca  # rigs keep the CA they were given
    text = subprocess.run(["openssl", "x509", "-in", str(tmp_path / "server.crt"), "-noout", "-text"],
                          capture_output=True, text=True, check=True).stdout
    assert "IP Address:127.0.0.2" in text and "DNS:pi-room4.local" in text
    (tmp_path / "ca.key").rename(tmp_path / "ca.key.away")  # kept apart, as the guide advises
    write_classroom_config(["r01", "r02"], tmp_path, tls_port=8883, addresses=["127.0.0.2"])  # nothing to issue
    with pytest.raises(ConfigError, match="ca.key is missing.*--new-ca"):
        write_classroom_config(["r01"], tmp_path, tls_port=8883, addresses=["10.9.8.7"])
    assert (tmp_path / "ca.crt").read_bytes() == ca
    write_classroom_config(["r01"], tmp_path, tls_port=8883, addresses=["10.9.8.7"], new_ca=True)
    assert (tmp_path / "ca.crt").read_bytes() != ca


@needs("openssl", "mosquitto")
def test_tls_reaches_the_broker_through_another_address_it_names(tmp_path):
    """127.0.0.2 plays the room's address a second laptop uses: named with --address, the link checks it."""
    from pendkit.link.broker import read_credentials

    with classroom_mosquitto(tmp_path, ["r01"], "127.0.0.2", addresses=["127.0.0.2"]) as (paths, _, tls_port):
        password = read_credentials(paths["credentials"])["host-r01"]
        link = RigLink("r01", f"mqtts://127.0.0.2:{tls_port}", "host-r01", password, str(paths["ca"]))
        link.connect(timeout_s=5)
        link.close()


@needs("openssl", "mosquitto")
def test_each_failed_connection_names_its_cause_in_one_line(tmp_path):
    """A name the certificate lacks, no CA, plain MQTT to the TLS port, TLS to the plain port, no broker."""
    from pendkit.link.broker import free_port, read_credentials
    from pendkit.link.driver import RigLinkError

    with classroom_mosquitto(tmp_path, ["r01"], "127.0.0.2") as (paths, port, tls_port):  # not naming .2
        password = read_credentials(paths["credentials"])["host-r01"]
        cases = [(f"mqtts://127.0.0.2:{tls_port}", str(paths["ca"]), "certificate does not name 127.0.0.2"),
                 (f"mqtts://127.0.0.2:{tls_port}", None, "not trusted"),
                 (f"mqtt://127.0.0.2:{tls_port}", None, "speaks TLS: connect with mqtts://"),
                 (f"mqtts://127.0.0.2:{port}", str(paths["ca"]), "does not speak TLS"),
                 (f"mqtt://127.0.0.2:{free_port()}", None, "nothing listens at")]
        for url, ca, cause in cases:
            with pytest.raises(RigLinkError) as refused:
                RigLink("r01", url, "host-r01", password, ca).connect(timeout_s=1.5)
            assert cause in str(refused.value) and "\n" not in str(refused.value), (url, str(refused.value))


@needs("openssl", "mosquitto")
def test_one_virtual_rig_process_logs_two_rigs_in_from_the_credentials_file_over_tls(tmp_path):
    """The guide's room: `pendkit virtual-rig --rig r01 --rig r02 --credentials ... --tls-ca ...`, each rig its
    own user, no password on the command line; each team's host then sees its own rig's observations."""
    import sys

    from pendkit.link.broker import read_credentials

    with classroom_mosquitto(tmp_path, ["r01", "r02"], "127.0.0.2", addresses=["127.0.0.2"]) as (paths, _, tls_port):
        url = f"mqtts://127.0.0.2:{tls_port}"
        rigs = subprocess.Popen([sys.executable, "-m", "pendkit.cli", "virtual-rig", "--rig", "r01", "--rig", "r02",
                                 "--broker", url, "--credentials", str(paths["credentials"]), "--tls-ca",
                                 str(paths["ca"])], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        try:
            credentials = read_credentials(paths["credentials"])
            for rig in ("r01", "r02"):
                link = RigLink(rig, url, f"host-{rig}", credentials[f"host-{rig}"], str(paths["ca"]))
                link.connect(timeout_s=5)
                deadline = time.monotonic() + 30
                while link.newest is None and time.monotonic() < deadline and rigs.poll() is None:
                    link.publish("h")
                    time.sleep(0.05)
                link.close()
                assert link.newest is not None, rigs.stdout.read() if rigs.poll() is not None else rig
            assert rigs.poll() is None  # both logged in and still serving
        finally:
            rigs.kill()
            rigs.wait()
