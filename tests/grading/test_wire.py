"""Values the grader sends to a student's kernel and back: data only, every kind a task takes."""

import json

import numpy as np
import pytest

from pendkit.grading import wire


@pytest.mark.parametrize("value", [
    b"\x00\x01\xffPK", b"", bytearray(b"\x10\x20"), [b"ab", bytearray(b"c")], {"blob": b"\xfe"},
    np.array([(1, 2.5), (3, -1.0)], dtype=[("count", "<i4"), ("angle_rad", "<f8")]),
    np.array([(1, [0.5, 1.5])], dtype=[("n", "u1"), ("pair", "<f4", (2,))]),
], ids=["bytes", "empty-bytes", "bytearray", "list-of-chunks", "dict", "records", "records-with-subarray"])
def test_values_a_task_takes_arrive_unchanged_and_of_the_same_type(value):
    back = wire.loads(wire.dumps(value))
    assert type(back) is type(value)
    if isinstance(value, np.ndarray):
        assert back.dtype == value.dtype and np.array_equal(back, value)
    else:
        assert back == value
        if isinstance(value, list):
            assert [type(item) for item in back] == [type(item) for item in value]


def test_a_record_array_with_objects_stays_opaque():
    records = np.array([(1, object())], dtype=[("n", "i4"), ("thing", "O")])
    assert isinstance(wire.loads(wire.dumps(records)), wire.Opaque)


@pytest.mark.parametrize("message", [
    {"bytes": "not base64!"}, {"ndarray": [[["n", "O"]], [1], ""]}, {"ndarray": [[["n"]], [1], ""]},
])
def test_malformed_bytes_or_records_are_refused_as_not_grading_messages(message):
    with pytest.raises(wire.WireError):
        wire.loads(json.dumps(message))
