"""`pendkit deploy` and `export` refuse in one line: a rig whose status lies, a controller designed for
another servo range, and a blob holding NaN."""

import dataclasses
import json

import numpy as np
import paho.mqtt.client as mqtt
import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import BlobError, pack
from pendkit.link.broker import EmbeddedBroker, free_port
from pendkit.link.virtual_rig import LocalRig
from pendkit.rig import RigParams


class LyingRig:
    """Answers every status request (`r`) with the status it is given, as a forger on an open broker can."""

    def __init__(self, url: str, status) -> None:
        self.status = status
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="liar")
        self.client.on_message = lambda client, userdata, message: self._answer(message.payload)
        host, port = url.removeprefix("mqtt://").split(":")
        self.client.connect(host, int(port))
        self.client.subscribe("pendulum-r/act/r01")
        self.client.loop_start()

    def _answer(self, payload: bytes) -> None:
        if payload.split(b":")[-1].split(b"@")[0] == b"r":
            self.client.publish("pendulum-r/status/r01", json.dumps(self.status))

    def close(self) -> None:
        self.client.loop_stop()
        self.client.disconnect()


@pytest.mark.parametrize("status", [
    [1, 2], {"protocol": 2, "controller": "yes"}, {"protocol": 2, "controller": {"accepted": "1"}},
    {"protocol": 2, "controller": {"accepted": True, "refused": 0, "received": 0, "total": 0, "bytes": 0,
                                   "running": False, "last_refusal": ""}},
])
def test_a_rig_whose_status_lies_is_named_not_a_traceback(status):
    with EmbeddedBroker(port=free_port()) as broker:
        liar = LyingRig(broker.url, status)
        try:
            result = CliRunner().invoke(main, ["deploy", "--rig", "r01", "--broker", broker.url, "--controller",
                                               "energy", "--seconds", "1"])
        finally:
            liar.close()
    assert result.exit_code == 1 and "Traceback" not in result.output, result.output
    assert "rig r01" in result.output and len(result.output.strip().splitlines()) <= 2


def test_a_controller_for_another_servo_range_is_not_uploaded():
    narrow = RigParams.preset("turnigy-tgy-wp23")
    rig = LocalRig(params=narrow)
    try:
        result = CliRunner().invoke(main, ["deploy", "--rig", rig.rig, "--broker", rig.url, "--controller", "energy",
                                           "--seconds", "1"])  # designed for the default rig's 150..450
        assert result.exit_code == 1 and "not uploaded" in result.output, result.output
        assert f"{narrow.servo_min_counts}..{narrow.servo_max_counts}" in result.output
        assert rig.virtual.device.mcu.onboard.blobs_accepted == 0
    finally:
        rig.stop()


def test_a_blob_holding_nan_is_refused_before_it_is_written():
    blob = design_swing_up(RigParams(), "energy")
    gain = blob.balance_gain.copy()
    gain[0] = np.nan
    with pytest.raises(BlobError, match="balance_gain holds NaN or infinity"):
        pack(dataclasses.replace(blob, balance_gain=gain))
    scalar = next(iter(blob.scalars))
    with pytest.raises(BlobError, match="NaN or infinity"):
        pack(dataclasses.replace(blob, scalars={**blob.scalars, scalar: float("inf")}))
    assert pack(blob)  # the design itself packs


@pytest.mark.parametrize("status", [[1, 2], {"servo_counts_range": "wide", "busy_s": "long"}, "null"])
def test_adaptation_reads_a_lying_status_as_saying_nothing(status):
    from pendkit.adapt.rigs import mqtt_rig

    with EmbeddedBroker(port=free_port()) as broker:
        liar = LyingRig(broker.url, status)
        try:
            rig = mqtt_rig("r01", broker.url)
            assert rig.prior() == RigParams()  # the default rig, not a crash
            assert rig.seconds() == 0.0
        finally:
            liar.close()
