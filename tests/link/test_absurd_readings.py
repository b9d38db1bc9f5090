"""Observations a device cannot send are malformed: counted, logged, and the link's state untouched."""

from types import SimpleNamespace

import pytest

from pendkit.device.protocol import ProtocolError
from pendkit.link.driver import RESYNC_AFTER_S, RigLink
from pendkit.rig import RigParams
from pendkit.telemetry.parse import ANY_DEVICE, ReadingLimits, parse_observation

GOOD_V2 = "R1000,10,512,300,0.5000,1.2000,10.0,0,3,99"


@pytest.mark.parametrize("payload, says", [
    ("S1000,512,300,1e38,0.0,0.0", "omega"),            # an exponent, and far beyond the encoder
    ("S1000,512,300,100000.0,0.0,0.0", "omega"),         # plain digits, still unresolvable
    ("S1000,512,300,nan,0.0,0.0", "omega"),
    ("S1000,512,300,inf,0.0,0.0", "omega"),
    ("S1000,512,99999999,0.0,0.0,0.0", "servo"),
    ("S1000,1_00,300,0.0,0.0,0.0", "position"),          # Python's int() would read 100
    ("S1000,512,300,0.0,1e300,0.0", "acceleration"),
    ("S1000,512,300,0.0,0.0,1e9", "arm rate"),
    ("S-5,512,300,0.0,0.0,0.0", "millis"),
    ("S99999999999,512,300,0.0,0.0,0.0", "millis"),
    ("R1000,4294967296,512,300,0.0,0.0,0.0,0,3,99", "seq"),
])
def test_values_no_device_can_report_are_rejected_with_the_field_named(payload, says):
    with pytest.raises(ProtocolError, match=says):
        parse_observation(payload)


def test_the_rigs_own_limits_are_tighter_than_any_devices():
    params = RigParams()  # servo 150..450 counts, 25 ms stream
    limits = ReadingLimits.for_rig(params)
    assert limits.max_rate_rev_s == pytest.approx(40.0) and ANY_DEVICE.max_rate_rev_s == pytest.approx(200.0)
    parse_observation("S1000,512,450,39.9,0.0,0.0", limits)
    with pytest.raises(ProtocolError, match="servo"):
        parse_observation("S1000,512,451,0.0,0.0,0.0", limits)  # a device with another servo range
    with pytest.raises(ProtocolError, match="omega"):
        parse_observation("S1000,512,300,41.0,0.0,0.0", limits)
    # a real pendulum at 3 rev/s and the servo's end stops pass
    assert parse_observation("S1000,1023,150,-3.0,-12.0,-2400.0", limits).observation.position_counts == 1023


def message(topic, text):
    return SimpleNamespace(topic=topic, payload=text.encode())


@pytest.fixture
def link():
    link = RigLink("r07", "mqtt://127.0.0.1:1")  # never connected: messages are fed by hand
    yield link
    link.client.loop_stop()


def test_a_spoofed_sequence_number_is_malformed_and_leaves_the_counters_alone(link):
    link._on_message(None, None, message(link.obs_topic, GOOD_V2))
    before = link.newest
    link._on_message(None, None, message(link.obs_topic, "R1040,4000000000,512,300,0.0,0.0,0.0,0,3,99"))
    assert link.counters.malformed == 1 and link.counters.dropped == 0 and link.newest is before
    link._on_message(None, None, message(link.obs_topic, "R1025,10,512,300,0.0,0.0,0.0,0,3,99"))  # a replay
    assert link.counters.malformed == 2 and link.newest is before
    link._on_message(None, None, message(link.obs_topic, "R1075,13,512,300,0.0,0.0,0.0,0,3,99"))  # 2 lost
    assert link.counters.dropped == 2 and link.newest.received.observation_seq == 13


def test_time_going_backwards_is_malformed_while_the_stream_is_live(link):
    link._on_message(None, None, message(link.obs_topic, "S5000,512,300,0.0,0.0,0.0"))
    link._on_message(None, None, message(link.obs_topic, "S4975,512,300,0.0,0.0,0.0"))
    assert link.counters.malformed == 1 and link.newest.received.observation.millis == 5000


def test_after_silence_a_restarted_device_is_picked_up_again(link):
    link._on_message(None, None, message(link.obs_topic, "R90000,5000,512,300,0.0,0.0,0.0,0,3,99"))
    stale = link.newest
    link.newest = type(stale)(stale.received, stale.receive_time_s - RESYNC_AFTER_S - 0.5)  # as if 1.5 s ago
    link._on_message(None, None, message(link.obs_topic, "R12,0,512,300,0.0,0.0,0.0,0,0,0"))  # rebooted
    assert link.counters.malformed == 0 and link.counters.resyncs == 1
    assert link.newest.received.observation.millis == 12


def feed(link, *payloads):
    for payload in payloads:
        link._on_message(None, None, message(link.obs_topic, payload))


def test_one_forged_observation_far_ahead_does_not_stop_the_real_stream(link):
    feed(link, "R1000,10,512,300,0.0,0.0,0.0,0,3,99")
    feed(link, "R1025,1010,512,300,0.0,0.0,0.0,0,3,99")  # forged: seq +1000
    feed(link, "R1025,11,512,300,0.0,0.0,0.0,0,3,99", "R1050,12,512,300,0.0,0.0,0.0,0,3,99")  # the real stream
    assert link.newest.received.observation_seq == 12
    assert link.counters.malformed == 1 and link.counters.dropped == 0 and link.counters.resyncs == 0
    feed(link, "R4294967295,13,512,300,0.0,0.0,0.0,0,3,99")  # forged: the device's clock at its end
    feed(link, "R1075,13,512,300,0.0,0.0,0.0,0,3,99")
    assert link.newest.received.observation.millis == 1075 and link.counters.malformed == 2


def test_time_jumping_ahead_of_the_hosts_clock_is_rejected(link):
    feed(link, "S5000,512,300,0.0,0.0,0.0", "S900000,512,300,0.0,0.0,0.0", "S5025,512,300,0.0,0.0,0.0")
    assert link.counters.malformed == 1 and link.newest.received.observation.millis == 5025


def test_a_device_that_restarts_mid_stream_is_followed_after_two_observations_that_agree(link):
    feed(link, "R90000,5000,512,300,0.0,0.0,0.0,0,3,99", "R12,0,512,300,0.0,0.0,0.0,0,0,0")
    assert link.newest.received.observation_seq == 5000 and link.counters.malformed == 1
    feed(link, "R37,1,512,300,0.0,0.0,0.0,0,0,0")  # follows the rejected one: a new stream
    assert link.newest.received.observation_seq == 1 and link.counters.resyncs == 1


@pytest.mark.parametrize("reported", [[], [150], ["150", "450"], [450, 150], "150..450", [True, 450]])
def test_a_malformed_servo_range_in_the_status_is_named_not_an_index_error(reported):
    import json

    from pendkit.link.driver import RigLinkError
    from pendkit.link.rig_backend import RigBackend

    backend = SimpleNamespace(link=SimpleNamespace(status=json.dumps({"servo_counts_range": reported})),
                              params=RigParams(), rig="r07")
    with pytest.raises(RigLinkError, match="malformed or forged"):
        RigBackend._check_device_config(backend)
