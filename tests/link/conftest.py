"""Brokers for the link tests: a real Mosquitto (Debian's, as in CI) and the embedded amqtt broker."""

import shutil

import pytest

from pendkit.link.broker import EmbeddedBroker, MosquittoBroker, free_port

HAVE_MOSQUITTO = shutil.which("mosquitto") is not None or shutil.os.path.exists("/usr/sbin/mosquitto")


@pytest.fixture(params=["mosquitto", "embedded"])
def broker_url(request, tmp_path):
    if request.param == "mosquitto":
        if not HAVE_MOSQUITTO:
            pytest.skip("mosquitto is not installed (apt-get install mosquitto; .ci/run installs it)")
        with MosquittoBroker(tmp_path / "mosquitto") as broker:
            yield broker.url
    else:
        with EmbeddedBroker(port=free_port()) as broker:
            yield broker.url


@pytest.fixture
def classroom(tmp_path):
    """Mosquitto with per-rig users and the ACL, for rigs r01 and r02."""
    if not HAVE_MOSQUITTO:
        pytest.skip("mosquitto is not installed")
    with MosquittoBroker(tmp_path / "classroom", rigs=["r01", "r02"]) as broker:
        yield broker
