"""When the device's own controller stops (k0, or a new blob accepted while it runs), the servo holds where
it is until the host commands again: it never resumes the host's target from before k1, nor a policy's last
ramp (the C++ core replays the same scenarios from tests/vectors/scheduler.json)."""

import pytest

from pendkit.device.onboard import blob_chunks
from pendkit.device.scheduler import DeviceScheduler
from pendkit.rig import RigParams
from tests.vectors.scheduler_scenarios import VECTORS_DIR, pendulum_counts

SWING_UP = (VECTORS_DIR / "swing-up-energy.pkcb").read_bytes()
POLICY = (VECTORS_DIR / "r-dqn-realistic-policy.pkcb").read_bytes()


class Device:
    """The device's loop, driven by hand: commands in, acting and streaming ticks every 10 ms."""

    def __init__(self) -> None:
        self.scheduler, self.now_ms = DeviceScheduler(RigParams()), 0

    def send(self, payload) -> None:
        self.scheduler.receive(payload, self.now_ms)

    def upload(self, blob: bytes) -> None:
        for chunk in blob_chunks(blob):
            self.send(chunk)

    def run(self, ms: int) -> list[int]:
        servo = []
        for _ in range(ms):
            self.now_ms += 1
            if self.scheduler.acting_due(self.now_ms):
                servo.append(self.scheduler.logic.acting_tick(self.now_ms, pendulum_counts(self.now_ms)))
            if self.scheduler.streaming_due(self.now_ms):
                self.scheduler.logic.streaming_tick(pendulum_counts(self.now_ms), self.now_ms)
            self.send("h")  # the host's heartbeat: the watchdog stays quiet
        return servo


def a_moved_servo(device: Device, host_target_counts: int) -> int:
    """Run the uploaded controller until it has moved the servo off the host's target; return where."""
    device.send("k1")
    for _ in range(50):
        moved = device.run(20)[-1]
        if moved != host_target_counts:
            return moved
    pytest.fail("the controller never moved the servo")


@pytest.mark.parametrize("stop", ["k0", "new blob"])
def test_a_stopped_swing_up_leaves_the_servo_where_it_was_not_at_the_old_target(stop):
    device = Device()
    device.send("b0.8")
    host_target = device.run(30)[-1]
    device.upload(SWING_UP)
    device.run(20)
    moved = a_moved_servo(device, host_target)
    if stop == "k0":
        device.send("k0")
    else:
        device.upload(SWING_UP)
    after = device.run(200)
    assert not device.scheduler.logic.onboard.running
    assert set(after) == {after[0]} and abs(after[0] - moved) <= 3 and after[0] != host_target


def test_a_stopped_policy_does_not_keep_its_last_ramp_to_the_arms_limit():
    device = Device()
    device.upload(POLICY)
    device.run(30)
    device.send("k1")
    device.run(300)
    device.send("k0")
    after = device.run(300)
    assert set(after) == {after[0]}, f"the servo kept moving after k0: {after[0]} -> {after[-1]}"


def test_a_host_command_after_the_stop_is_obeyed_at_once():
    device = Device()
    device.upload(SWING_UP)
    device.run(20)
    device.send("k1")
    device.run(100)
    device.send("k0")
    device.run(50)
    device.send("b-0.5")
    assert device.run(30)[-1] == round(RigParams().servo_centre_counts - 0.5 * RigParams().servo_span_counts / 2)
