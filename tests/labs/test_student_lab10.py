"""Lab 10: the student's model and chunker drive the device's estimate and the upload."""

import re

import pytest

from tests.labs.student_loop import printed_by_lab

pytestmark = pytest.mark.expensive  # minutes of notebook runs: scheduled first (conftest.py)

PUSH_WITH_THE_WRONG_SIGN = '''
def pendulum_acceleration(angle_rad, rate_rad_s, arm_acceleration_rad_s2, natural_frequency_rad_s,
                          damping_per_s, coupling):
    return (-natural_frequency_rad_s**2 * math.sin(angle_rad) - damping_per_s * rate_rad_s
            + coupling * math.cos(angle_rad) * arm_acceleration_rad_s2)  # the arm's push reversed
'''
BIG_ENDIAN_CHUNKS = '''
def upload_chunks(blob, start=0, chunk_bytes=1024):
    return [b"PKUP" + struct.pack(">II", offset, len(blob)) + blob[offset:offset + chunk_bytes]
            for offset in range(start, len(blob), chunk_bytes)]
'''


def estimate_error(text: str, whose: str = "your model") -> float:
    return float(re.search(whose + r" ([\d.]+) rad/s", text).group(1))


def test_lab10_the_students_model_drives_the_devices_estimate_and_a_reversed_push_shows():
    right = printed_by_lab("10_on_device.ipynb", "onboard.runtime.pendulum_acceleration")
    wrong = printed_by_lab("10_on_device.ipynb", "onboard.runtime.pendulum_acceleration",
                           {"pendulum_acceleration": PUSH_WITH_THE_WRONG_SIGN})
    assert "solved=2/2" in right, right
    assert estimate_error(wrong) > 1.3 * estimate_error(right), (right, wrong)
    # the kit's own model is printed beside the student's, and a wrong one is told so
    assert estimate_error(right, "the kit's model") == pytest.approx(estimate_error(right), abs=0.02), right
    assert "clearly worse than the kit's" in wrong and "clearly worse" not in right, (right, wrong)


def test_lab10_the_students_chunks_reach_the_rig_and_big_endian_ones_do_not():
    import pendkit
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack

    right = printed_by_lab("10_on_device.ipynb", "chunker=your_chunks")
    wrong = printed_by_lab("10_on_device.ipynb", "chunker=your_chunks", {"upload_chunks": BIG_ENDIAN_CHUNKS})
    # 2 chunks, or more when the busy room's WiFi lost one and the upload resumed
    size = len(pack(design_swing_up(pendkit.RigParams(), "trajopt")))  # the notebook's blob, as the device designs it
    assert 1024 < size <= 2048, size  # the text: "a little over 1 KB: a chunk of 1024 bytes and one with the rest"
    assert re.search(rf"the rig took the controller: {size} bytes in [2-9] chunks", right), right
    assert "1 accepted" in right, right
    assert "the upload failed" in wrong and "0 accepted" in wrong, wrong
    assert "big-endian; the rig reads little-endian" in wrong, wrong  # the cause, not the blob's size


CHUNKS_ONE_BYTE_SHORT = '''
def upload_chunks(blob, start=0, chunk_bytes=1024):
    return [b"PKUP" + struct.pack("<II", offset, len(blob)) + blob[offset:offset + chunk_bytes - 1]
            for offset in range(start, len(blob), chunk_bytes)]
'''


def test_lab10_chunks_one_byte_short_are_named_before_they_are_sent():
    said = printed_by_lab("10_on_device.ipynb", "chunker=your_chunks", {"upload_chunks": CHUNKS_ONE_BYTE_SHORT})
    assert "the upload failed" in said and "byte 1023 is never sent" in said, said
    assert "a slice's end is left out" in said, said
