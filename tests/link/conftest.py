"""Brokers for the link tests: a real Mosquitto (Debian's, as in CI) and the embedded amqtt broker."""

import pytest

from pendkit.link.broker import EmbeddedBroker, MosquittoBroker, free_port
from tests.system_needs import skip_unless


@pytest.fixture(params=["mosquitto", "embedded"])
def broker_url(request, tmp_path):
    if request.param == "mosquitto":
        skip_unless("mosquitto")
        with MosquittoBroker(tmp_path / "mosquitto") as broker:
            yield broker.url
    else:
        with EmbeddedBroker(port=free_port()) as broker:
            yield broker.url


@pytest.fixture
def classroom(tmp_path):
    """Mosquitto with per-rig users and the ACL, for rigs r01 and r02."""
    skip_unless("mosquitto")
    with MosquittoBroker(tmp_path / "classroom", rigs=["r01", "r02"]) as broker:
        yield broker
