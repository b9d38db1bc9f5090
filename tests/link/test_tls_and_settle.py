"""TLS to the broker when configured, and the reset that waits for the pendulum to settle."""

import os
import subprocess
import time

import pytest

import pendkit
from pendkit.link.broker import free_port, mosquitto_binary, wait_for_port
from pendkit.link.driver import RigLink, RigLinkError
from pendkit.link.virtual_rig import LocalRig
from tests.system_needs import needs


def make_certificates(folder):
    """A throwaway CA and a server certificate for 127.0.0.1 signed by it."""
    run = lambda *args: subprocess.run(["openssl", *args], cwd=folder, check=True, capture_output=True)  # noqa: E731
    run("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "2", "-subj", "/CN=pendkit test CA",
        "-keyout", "ca.key", "-out", "ca.crt")
    run("req", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=127.0.0.1", "-keyout", "server.key",
        "-out", "server.csr")
    (folder / "san.ext").write_text("subjectAltName=IP:127.0.0.1\n")
    run("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key", "-CAcreateserial", "-days", "2",
        "-extfile", "san.ext", "-out", "server.crt")
    for name in ("ca.crt", "server.crt", "server.key"):
        os.chmod(folder / name, 0o644)


@needs("openssl", "mosquitto")
def test_tls_link_connects_with_the_ca_and_not_without(tmp_path):
    make_certificates(tmp_path)
    port = free_port()
    conf = tmp_path / "mosquitto.conf"
    conf.write_text(f"listener {port} 127.0.0.1\nallow_anonymous true\ncafile {tmp_path / 'ca.crt'}\n"
                    f"certfile {tmp_path / 'server.crt'}\nkeyfile {tmp_path / 'server.key'}\n"
                    + ("user root\n" if os.geteuid() == 0 else ""))
    binary = mosquitto_binary()
    broker = subprocess.Popen([binary, "-c", str(conf)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        assert wait_for_port("127.0.0.1", port)
        link = RigLink("r01", f"mqtts://127.0.0.1:{port}", tls_ca=str(tmp_path / "ca.crt"))
        link.connect(timeout_s=5)
        link.client.publish(link.status_topic, '{"online": true}')
        deadline = time.monotonic() + 3
        while link.status is None and time.monotonic() < deadline:
            time.sleep(0.02)
        assert link.status == '{"online": true}'  # a round trip over TLS
        link.close()
        with pytest.raises(RigLinkError):  # the system's CAs do not know our test CA
            RigLink("r01", f"mqtts://127.0.0.1:{port}").connect(timeout_s=2)
    finally:
        broker.kill()
        broker.wait()


def test_reset_waits_for_the_pendulum_to_settle():
    rig = LocalRig()
    try:
        env = pendkit.make(backend="rig", broker=rig.url, rig=rig.rig,
                           # this test is about settling: a reading late under a loaded worker is not its failure
                           rig_options={"reset_stop_s": 0.2, "settle": True, "observation_timeout_s": 3.0})
        started = time.monotonic()
        env.reset(seed=0)  # hanging still: settled after the 1 s hold
        assert time.monotonic() - started >= 1.0  # held still for the 1 s hold
        rig.virtual.device.data.qvel[rig.virtual.device._pendulum_qpos] = 4.0  # set it swinging
        time.sleep(0.2)
        started = time.monotonic()
        env.reset(seed=1)
        assert time.monotonic() - started > 3.0  # waited for the swing to die down
        assert abs(env.unwrapped.backend.link.newest.received.observation.omega_rev_s) < 0.05
        env.close()
    finally:
        rig.stop()


def test_a_rig_built_for_another_servo_is_refused_by_name_even_while_its_readings_are_lost():
    """The servo check reads the device's retained status: a CI run under load lost the readings for a second
    and got "no observation from rig r01" instead of the two servos named. The status alone now decides."""
    import dataclasses

    from pendkit.errors import ConfigError

    rig = LocalRig()  # the kit's rig: Hitec D645MW
    try:
        rig.virtual.impairment = dataclasses.replace(rig.virtual.impairment, observation_loss_pct=100.0)
        env = pendkit.make(backend="rig", broker=rig.url, rig=rig.rig,
                           params=pendkit.RigParams.preset("turnigy-tgy-wp23"))
        with pytest.raises(ConfigError, match="hitec-d645mw") as refused:
            env.reset(seed=0)
        assert "Turnigy TGY-WP23" in str(refused.value)
        env.close()
    finally:
        rig.stop()
