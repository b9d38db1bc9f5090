"""The device vectors (replayed by the firmware's ctest) are current, and mean what they say."""

import json
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pendkit.device.commands import REASONS, parse_command
from pendkit.device.protocol import ProtocolError
from pendkit.firmware_constants import render_header
from pendkit.telemetry.parse import parse_observation_v1
from tests.vectors.make_device_vectors import build

ROOT = Path(__file__).resolve().parents[2]


def test_device_vectors_are_not_stale():
    for name, content in build().items():
        committed = json.loads((ROOT / "tests" / "vectors" / name).read_text())
        stale = f"{name} is stale: run python -m tests.vectors.make_device_vectors"
        assert json.loads(json.dumps(content)) == committed, stale


def test_firmware_constants_header_matches_rig_params():
    header = ROOT / "firmware" / "lib" / "pendcore" / "src" / "rig_constants.h"
    regenerate = "regenerate: pendkit firmware-header > firmware/lib/pendcore/src/rig_constants.h"
    assert header.read_text() == render_header(), regenerate


@given(st.text(max_size=80) | st.binary(max_size=80).map(lambda b: b.decode("latin-1")))
def test_command_parsing_is_total(text):
    try:
        parse_command(text)
    except ProtocolError as error:
        assert error.reason in REASONS


@given(st.binary(max_size=80))
def test_observation_parsing_is_total(payload):
    try:
        parse_observation_v1(payload)
    except ProtocolError:
        pass


@pytest.mark.parametrize("text, kind, value", [("g", "action", 4), ("#7:b-0.5@12", "target", -0.5),
                                                ("w200", "watchdog_timeout", 200), ("p0", "overspin_limit", 0)])
def test_commands_mean_what_the_protocol_says(text, kind, value):
    command = parse_command(text)
    assert (command.kind, command.value) == (kind, value)


def test_the_scenarios_exercise_every_safety_stop():
    vectors = json.loads((ROOT / "tests" / "vectors" / "device.json").read_text())
    scenarios = {s["name"]: s for s in vectors["scenarios"]}

    def bits(name):
        result = 0
        for item in scenarios[name]["expected"]:
            result |= item.get("flags", 0)
        return result
    assert bits("discrete_to_the_limit") & 1
    assert bits("overspin_holds") & 2
    assert bits("bad_frames_make_stuck") & 4 and bits("bad_frames_make_stuck") & 16
    assert bits("no_change_while_moving_is_stuck") & 4
    assert bits("watchdog_holds_then_heartbeat") & 8
