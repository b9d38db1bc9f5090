import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from pendkit import encoder
from pendkit.errors import FrameError

VECTORS = Path(__file__).parent / "vectors"


def load(name):
    return json.loads((VECTORS / name).read_text())


def test_frame_bit_layout_by_hand():
    # position 512 = 0b1000000000 -> bit 15; OCF (bit 5) set; two ones -> parity bit 0
    assert encoder.encode_ssi_frame(512) == (1 << 15) | (1 << 5)
    assert encoder.decode_ssi_frame((1 << 15) | (1 << 5)).position_counts == 512
    # position 1 -> bit 6; OCF; two ones -> even already
    assert encoder.decode_ssi_frame((1 << 6) | (1 << 5)).position_counts == 1


@pytest.mark.parametrize("flags, reason", [
    ({"corrupt_parity": True}, "parity"),
    ({"offset_compensated": False}, "offset_compensation_not_finished"),
    ({"cordic_overflow": True}, "cordic_overflow"),
    ({"linearity_alarm": True}, "linearity_alarm"),
    ({"magnet_closer": True, "magnet_away": True}, "magnet_out_of_range"),
])
def test_bad_frames_are_rejected_with_their_reason(flags, reason):
    with pytest.raises(FrameError, match=reason):
        encoder.decode_ssi_frame(encoder.encode_ssi_frame(700, **flags))


def test_one_magnet_direction_bit_alone_is_fine():
    reading = encoder.decode_ssi_frame(encoder.encode_ssi_frame(5, magnet_closer=True))
    assert reading.position_counts == 5 and reading.magnet_moving_closer


def test_frame_vectors_scalar_and_vectorised():
    data = load("encoder_frames.json")
    frames = np.array([c["frame"] for c in data["cases"]])
    positions, reasons = encoder.decode_ssi_frames(frames)
    for case, position, reason in zip(data["cases"], positions, reasons):
        assert encoder.frame_status(case["frame"]) == case["status"]
        assert data["reasons"][reason] == case["status"]
        if case["status"] == "ok":
            assert encoder.decode_ssi_frame(case["frame"]).position_counts == case["position_counts"] == position


@given(st.integers(0, 1023), st.booleans(), st.booleans())
def test_any_frame_with_one_bit_flipped_fails_parity(position, closer, away):
    frame = encoder.encode_ssi_frame(position, magnet_closer=closer, magnet_away=away and not closer)
    for bit in range(16):
        assert encoder.frame_status(frame ^ (1 << bit)) != "ok"


def test_wrap_vectors():
    data = load("wrap_delta.json")
    for case in data["cases"]:
        assert encoder.wrap_delta_counts(case["new"], case["old"]) == case["delta"], case


def test_wrap_takes_the_shorter_way():
    assert encoder.wrap_delta_counts(0, 1023) == 1
    assert encoder.wrap_delta_counts(1023, 0) == -1
    assert encoder.wrap_delta_counts(10, 1010) == 24
    np.testing.assert_array_equal(encoder.wrap_delta_counts([0, 1023], [1023, 0]), [1, -1])


@given(st.integers(0, 1023), st.integers(-511, 511))
def test_wrap_recovers_any_step_shorter_than_half_a_turn(start, step):
    assert encoder.wrap_delta_counts((start + step) % 1024, start) == step


def test_counts_rad_vectors_and_zero_at_the_bottom():
    for case in load("counts_rad.json")["cases"]:
        assert encoder.counts_to_rad(case["raw_counts"], case["offset_counts"]) == pytest.approx(
            case["angle_from_bottom_rad"], abs=1e-12)
    assert encoder.counts_to_rad(512) == pytest.approx(math.pi)  # 512 is the top
    assert encoder.angle_from_upright_rad(math.pi) == pytest.approx(0.0)


def test_exactly_1024_levels_and_round_trip():
    angles = np.linspace(0, 2 * math.pi, 200_000, endpoint=False)
    counts = encoder.rad_to_counts(angles, offset_counts=317)
    assert len(np.unique(counts)) == 1024
    back = encoder.counts_to_rad(counts, offset_counts=317)
    assert np.max(angles - back) < 2 * math.pi / 1024 and np.min(angles - back) >= -1e-12


def test_velocity_vectors_vectorised_and_streaming():
    data = load("velocity.json")
    for seq in data["sequences"]:
        mean, accel = encoder.firmware_velocity(seq["positions"], seq["times_ms"], data["window"])
        np.testing.assert_allclose(mean, seq["omega_rev_s"], atol=data["tolerance"])
        np.testing.assert_allclose(accel, seq["accel_rev_s2"], atol=data["tolerance"])
        estimator = encoder.FirmwareVelocityEstimator(data["window"])
        streamed = [estimator.update(p, t) for p, t in zip(seq["positions"], seq["times_ms"])]
        np.testing.assert_allclose([s[0] for s in streamed], seq["omega_rev_s"], atol=data["tolerance"])
        np.testing.assert_allclose([s[1] for s in streamed], seq["accel_rev_s2"], atol=data["tolerance"])


def test_velocity_units_rev_s():
    # 51 counts per 25 ms = 51/1024 rev / 0.025 s ~ 1.99 rev/s
    assert encoder.velocity_rev_s(51, 25.0) == pytest.approx(51 / 1024 / 0.025)
    fd = encoder.finite_difference_rev_s([1020, 2], [0, 25])
    assert fd[0] == pytest.approx(6 / 1024 / 0.025)


def test_low_pass_settles_and_cuts_noise():
    rng = np.random.default_rng(0)
    noisy = 1.0 + 0.2 * rng.standard_normal(2000)
    smooth = encoder.low_pass(noisy, encoder.low_pass_alpha(2.0, 25.0))
    assert abs(smooth[-500:].mean() - 1.0) < 0.02
    assert smooth[-500:].std() < noisy.std() / 2


def test_committed_vectors_are_not_stale():
    from tests.vectors.make_vectors import build

    for name, content in build().items():
        assert json.loads(json.dumps(content)) == load(name), f"{name} is stale: run tests/vectors/make_vectors.py"
