"""Controller blobs for the device: a blob round-trips, a damaged, cut or oversized one is refused whole,
and the device's float32 runtime gives torch's outputs on 10 000 recorded inputs of the shipped R-DQN
(tests/vectors/r-dqn-realistic.*, rebuilt by `python -m pendkit.deploy.export vectors tests/vectors`)."""

import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from pendkit.deploy.export import read_vectors, state_feedback_blob
from pendkit.device.controller_blob import HEADER, MAX_BLOB_BYTES, BlobError, DenseLayer, NetworkBlob, pack, parse
from pendkit.device.policy_runtime import runtime_for

VECTORS = Path(__file__).resolve().parents[1] / "vectors"


def small_network(rng) -> NetworkBlob:
    n_in, gru = 4, 3
    return NetworkBlob(rng.normal(size=n_in).astype(np.float32), rng.uniform(0.5, 2, n_in).astype(np.float32), 5.0,
                       [DenseLayer(rng.normal(size=(6, n_in + gru)).astype(np.float32), np.zeros(6, np.float32),
                                   "relu"),
                        DenseLayer(rng.normal(size=(3, 6)).astype(np.float32), np.ones(3, np.float32))],
                       tuple(rng.normal(size=s).astype(np.float32) for s in ((9, n_in), (9, gru), (9,), (9,))))


def test_a_blob_round_trips_exactly():
    blob = small_network(np.random.default_rng(0))
    again = parse(pack(blob))
    assert again.input_dim == 4 and again.gru_size == 3
    assert [layer.activation for layer in again.layers] == ["relu", "none"]
    assert pack(again) == pack(blob)
    feedback = parse(pack(state_feedback_blob([1.0, -20.0, 0.5, -2.0], [0, np.pi, 0, 0], 1.5)))
    assert feedback.output_limit == 1.5 and feedback.gain[1] == -20.0


def recrc(data: bytes) -> bytes:
    return data[:-4] + struct.pack("<I", zlib.crc32(data[:-4]))


@pytest.mark.parametrize("damage, says", [
    (lambda b: b[:-1], "payload"),  # cut
    (lambda b: b[:HEADER.size + 10], "payload"),
    (lambda b: b[:5] + bytes([b[5] ^ 1]) + b[6:], "version"),
    (lambda b: b[:40] + bytes([b[40] ^ 0x10]) + b[41:], "CRC"),  # one bit flipped in a weight
    (lambda b: b"XXXX" + b[4:], "magic"),
    (lambda b: b + b"\0" * 4, "payload"),
    (lambda b: b"", "too short"),
    (lambda b: recrc(b[:HEADER.size - 4] + struct.pack("<I", 10**6) + b[HEADER.size:]), "payload"),
    (lambda b: b"\0" * (MAX_BLOB_BYTES + 1), "more than a rig takes"),
])
def test_damaged_cut_or_oversized_blobs_are_refused(damage, says):
    with pytest.raises(BlobError, match=says):
        parse(damage(pack(small_network(np.random.default_rng(1)))))


def test_shapes_that_disagree_with_the_payload_are_refused_even_with_a_good_crc():
    data = bytearray(pack(small_network(np.random.default_rng(2))))
    struct.pack_into("<H", data, HEADER.size, 5)  # 5 inputs where the weights are for 4
    with pytest.raises(BlobError):
        parse(recrc(bytes(data)))
    nan_weight = bytearray(pack(small_network(np.random.default_rng(2))))
    struct.pack_into("<f", nan_weight, len(nan_weight) - 8, float("nan"))
    with pytest.raises(BlobError, match="finite"):
        parse(recrc(bytes(nan_weight)))


def test_the_device_runtime_gives_torchs_outputs_on_the_recorded_inputs():
    blob = parse((VECTORS / "r-dqn-realistic.pkcb").read_bytes())
    starts, inputs, expected = read_vectors(VECTORS / "r-dqn-realistic.pktv")
    assert len(inputs) == 10_000 and starts.sum() >= 20
    runtime = runtime_for(blob)
    outputs = np.empty_like(expected)
    actions = np.empty(len(inputs), dtype=int)
    for k, x in enumerate(inputs):
        if starts[k]:
            runtime.reset()
        outputs[k], actions[k] = runtime.step(x)
    # Q-values reach 150 in size, where float32's own spacing is 1.5e-5: the error is held relative to them
    assert np.max(np.abs(outputs - expected) / np.maximum(1.0, np.abs(expected))) <= 1e-6
    assert np.mean(actions == expected.argmax(axis=1)) >= 0.999


def test_the_vectors_are_the_shipped_policys():
    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.runs import build_run

    spec, state = policy_weights("r-dqn-realistic")
    env, agent, _ = build_run(spec)
    agent.load_policy(state)
    env.close()
    assert pack(agent.device_network()) == (VECTORS / "r-dqn-realistic.pkcb").read_bytes()


def test_export_writes_the_shipped_policy_as_the_devices_policy_blob(tmp_path):
    from click.testing import CliRunner

    from pendkit.cli import main

    result = CliRunner().invoke(main, ["export", "--policy", "r-dqn-realistic", "--out", str(tmp_path / "p.pkcb")])
    assert result.exit_code == 0, result.output
    assert "11456 multiply-accumulates" in result.output
    assert (tmp_path / "p.pkcb").read_bytes() == (VECTORS / "r-dqn-realistic-policy.pkcb").read_bytes()
    assert parse((tmp_path / "p.pkcb").read_bytes()).network.input_dim == 12
