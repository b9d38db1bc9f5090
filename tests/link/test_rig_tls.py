"""TLS as a rig sees it: the virtual rig checks the broker's name as the firmware does, and the classroom
certificate names each IPv4 address in a form a rig's Mbed TLS 2.x can check (it matches DNS entries only)."""

import subprocess

import pytest

from pendkit.link.broker import read_credentials, write_classroom_config
from pendkit.link.driver import RigLinkError
from pendkit.link.virtual_rig import VirtualRig
from tests.link.test_classroom_teams import classroom_mosquitto
from tests.system_needs import needs


def subject_names(certificate) -> str:
    return subprocess.run(["openssl", "x509", "-in", str(certificate), "-noout", "-ext", "subjectAltName"],
                          capture_output=True, text=True, check=True).stdout


@needs("openssl", "mosquitto")
@pytest.mark.parametrize("named", [True, False], ids=["certificate-names-it", "certificate-does-not"])
def test_a_virtual_rig_connects_only_to_a_broker_whose_certificate_names_its_address(tmp_path, named):
    addresses = ["127.0.0.2"] if named else []
    with classroom_mosquitto(tmp_path, ["r01"], "127.0.0.2", addresses=addresses) as (paths, _, tls_port):
        rig = VirtualRig("r01", f"mqtts://127.0.0.2:{tls_port}", username="r01",
                         password=read_credentials(paths["credentials"])["r01"], tls_ca=str(paths["ca"]))
        if named:
            rig.connect(timeout_s=5)
            rig.close()
            return
        with pytest.raises(RigLinkError) as refused:
            rig.connect(timeout_s=1.5)
        message = str(refused.value)
        assert "certificate does not name 127.0.0.2" in message and "\n" not in message, message


@needs("openssl")
def test_each_ipv4_address_is_named_for_openssl_and_for_a_rigs_mbed_tls(tmp_path):
    paths = write_classroom_config(["r01"], tmp_path, tls_port=8883, addresses=["10.1.2.3", "fd00::7", "pi.local"])
    names = subject_names(paths["cert"])
    assert "IP Address:10.1.2.3" in names and "DNS:10.1.2.3" in names  # OpenSSL checks one, Mbed TLS 2.x the other
    assert "DNS:pi.local" in names
    assert "IP Address:FD00:0:0:0:0:0:0:7" in names and "DNS:fd00::7" not in names  # rigs on the room's WiFi use IPv4


@needs("openssl")
def test_a_certificate_issued_without_the_dns_twins_is_issued_again_from_the_same_ca(tmp_path):
    paths = write_classroom_config(["r01"], tmp_path, tls_port=8883, addresses=["10.1.2.3"])
    ca, certificate = paths["ca"].read_bytes(), paths["cert"].read_bytes()
    write_classroom_config(["r01"], tmp_path, tls_port=8883, addresses=["10.1.2.3"])
    assert paths["cert"].read_bytes() == certificate  # current: kept
    san = tmp_path / "san.ext"
    san.write_text(",".join(part for part in san.read_text().strip().split(",")  # as an earlier kit wrote it
                            if not part.startswith("DNS:10.")) + "\n")
    write_classroom_config(["r01"], tmp_path, tls_port=8883, addresses=["10.1.2.3"])
    assert paths["ca"].read_bytes() == ca  # every rig and host keeps its ca.crt
    assert paths["cert"].read_bytes() != certificate
    assert "DNS:10.1.2.3" in subject_names(paths["cert"])
