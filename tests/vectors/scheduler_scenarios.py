"""Scenarios for the device's loop (`pendkit.device.scheduler` and the C++ `pend::Scheduler`): commands
arrive as text at given milliseconds, the loop runs at given milliseconds, and every outcome (command
taken or not, status, acting tick, observation line) is recorded. The C++ test replays the same loop.
A command written `hex:...` is a binary upload chunk (`pendkit.device.onboard`), sent as its bytes."""

from __future__ import annotations

from pathlib import Path

from pendkit.device.onboard import blob_chunks
from pendkit.device.scheduler import DeviceScheduler
from pendkit.encoder import encode_ssi_frame
from pendkit.rig import RigParams


def pendulum_counts(now_ms: int) -> int:
    """A pendulum turning a count every 3 ms (0.33 rev/s): the encoder's raw position."""
    return (now_ms // 3) % 1024


def pendulum_frame(now_ms: int) -> int:
    """The same position as the encoder would frame it."""
    return encode_ssi_frame(pendulum_counts(now_ms))


def every_ms(first: int, last: int) -> list[int]:
    return list(range(first, last + 1))


VECTORS_DIR = Path(__file__).parent


def swing_up_chunks() -> list[str]:
    """The kit's energy swing-up for the default rig, as the upload chunks a host sends."""
    blob = (VECTORS_DIR / "swing-up-energy.pkcb").read_bytes()
    return ["hex:" + chunk.hex() for chunk in blob_chunks(blob)]


def payload(text: str) -> str | bytes:
    return bytes.fromhex(text[4:]) if text.startswith("hex:") else text


SCENARIOS = {
    "v1_host_periods_and_streaming": {
        "commands": [[0, "g"], [40, "u10"], [95, "y"], [130, "z"], [150, "x"], [170, "i20"], [200, "r"],
                     [205, "#x:g"], [210, "d"], [230, "b0.5"], [260, "u40"]],
        "loop_ms": every_ms(0, 320)},
    "v2_echo_and_sequence": {
        "commands": [[0, "#1:g@1000"], [30, "#2:h@1030"], [61, "#3:n2@1061"], [90, "#4:b-0.25@1090"],
                     [120, "#5:r@1120"], [121, "#6:q@1121"], [150, "#7:y@1150"], [175, "#8:z@1175"]],
        "loop_ms": every_ms(0, 200)},
    # A controller that stops leaves the servo holding where it is: after k0, and after a new blob is
    # accepted while it runs; never the host's target from before k1 (issue 44).
    "controller_stopped_by_k0_holds_the_servo": {
        "commands": [[0, "#1:b0.8@0"], [40, swing_up_chunks()[0]], [60, "#2:k1@60"], [140, "#3:k0@140"],
                     [190, "#4:h@190"]],
        "loop_ms": every_ms(0, 240)},
    "controller_replaced_by_a_new_blob_holds_the_servo": {
        "commands": [[0, "#1:b-0.6@0"], [40, swing_up_chunks()[0]], [60, "#2:k1@60"], [140, swing_up_chunks()[0]],
                     [190, "#3:h@190"]],
        "loop_ms": every_ms(0, 240)},
    "late_loop_skips_never_bursts": {
        "commands": [[0, "#1:f@5"], [10, "#2:h@15"], [160, "#3:h@165"]],
        "loop_ms": every_ms(0, 60) + [155, 156, 157] + every_ms(230, 260)},
}


def run_loop(commands: list, loop_ms: list[int], params: RigParams) -> list[dict]:
    scheduler = DeviceScheduler(params)
    pending = list(commands)
    records: list[dict] = []
    for now_ms in loop_ms:
        while pending and pending[0][0] <= now_ms:
            text = pending.pop(0)[1]
            records.append({"t": now_ms, "cmd": text, "taken": scheduler.receive(payload(text), now_ms) is not None})
        if scheduler.take_status_request():
            records.append({"t": now_ms, "status": scheduler.status()})
        if scheduler.acting_due(now_ms):
            records.append({"t": now_ms, "act": scheduler.logic.acting_tick(now_ms, pendulum_counts(now_ms))})
        if scheduler.streaming_due(now_ms):
            frame = pendulum_frame(now_ms)
            observation = scheduler.logic.streaming_frame(frame, now_ms)
            records.append({"t": now_ms, "frame": frame, "line": scheduler.observation_line(observation)})
    return records


def scheduler_vectors() -> dict:
    params = RigParams()
    return {"description": "the device's loop: commands (text) at their ms, the loop at loop_ms; each record "
                           "is a command taken or not, a status, an acting tick's servo counts, or an "
                           "observation line from the encoder frame given (the pendulum turns a count every 3 ms)",
            "scenarios": [{"name": name, **spec, "records": run_loop(spec["commands"], spec["loop_ms"], params)}
                          for name, spec in SCENARIOS.items()]}
