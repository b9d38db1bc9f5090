"""reset() waits for the first observation for the time it states (a device just told to stream, a slow
network), and says that time when it gives up."""

import threading
import time

import paho.mqtt.client as mqtt
import pytest

import pendkit
from pendkit.link.driver import RigLinkError, topics


def late_device(url: str, rig: str, first_after_s: float, stop: threading.Event) -> threading.Thread:
    """A stand-in device that stays silent for `first_after_s`, then streams v1 observations every 25 ms."""
    host, port = url.removeprefix("mqtt://").split(":")

    def run():
        client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"late-{rig}")
        client.connect(host, int(port))
        client.loop_start()
        time.sleep(first_after_s)
        millis = 0
        while not stop.is_set():
            client.publish(topics(rig)[0], f"S{millis},0,300,0.0000,0.0000,0.0")
            millis += 25
            time.sleep(0.025)
        client.loop_stop()
        client.disconnect()

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread


def test_reset_waits_for_a_device_that_starts_streaming_late(broker_url):
    stop = threading.Event()
    late_device(broker_url, "r05", 0.4, stop)
    env = pendkit.make(backend="rig", rig="r05", broker=broker_url,
                       rig_options={"reset_stop_s": 0.2, "observation_timeout_s": 1.5})
    try:
        observation, _ = env.reset(seed=0)  # gave up after 0.05 s before: the first reading came at 0.4 s
        assert observation[0] == pytest.approx(-3.1416, abs=0.01)
    finally:
        stop.set()
        env.close()


def test_reset_gives_up_after_the_stated_time_and_says_it(broker_url):
    env = pendkit.make(backend="rig", rig="r06", broker=broker_url,
                       rig_options={"reset_stop_s": 0.2, "observation_timeout_s": 0.3})
    try:
        started = time.monotonic()
        with pytest.raises(RigLinkError, match=r"within 0.3 s \(none yet\)"):
            env.reset(seed=0)
        assert time.monotonic() - started >= 0.3  # not before the stated time (a lower bound only)
    finally:
        env.close()
