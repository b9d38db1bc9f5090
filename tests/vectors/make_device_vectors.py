"""Vectors for the device's logic and protocol, generated from the Python reference and replayed by the
firmware's C++ tests: commands.json (parsing), observations.json (formatting), device.json (scenarios),
scheduler.json (the device's loop).

Run `python -m tests.vectors.make_device_vectors` (from the repository root) after a deliberate change;
a test fails when stale.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from pendkit.device.commands import parse_command
from pendkit.device.logic import McuLogic, McuObservation, round_half_up
from pendkit.device.protocol import ProtocolError, format_observation_v1, format_observation_v2
from pendkit.encoder import encode_ssi_frame
from pendkit.rig import RigParams
from tests.vectors.scheduler_scenarios import scheduler_vectors

HERE = Path(__file__).parent
COMMANDS = [
    "a", "s", "d", "f", "g", "m0", "m4", "m5", "m-1", "b0.25", "b-1", "b1.0", "b+.5", "b1.0001", "b2", "b", "bnan",
    "binf", "b1e-3", "b0.12345678901234", "b0.123456789012345678", "o317", "o1024", "o-1", "u25", "u4", "u1001",
    "i10", "e0.85", "e1", "e0.999", "z", "x", "y", "c", "v", "h", "r", "w150", "w49", "w5000", "p2", "p0", "p0.4",
    "p20.5", "q", "", " ", "g\n", "gg", "#7:g", "#4294967295:h", "#4294967296:h", "#:g", "#12g", "#1:", "g@1234",
    "#3:b0.5@99", "b0.5@", "b0.5@x", "@5", "S1,2,3", "m2.0", "u+25", "a" * 65, "b\u00e9", "g@\u00b2", "#1:g\nh",
    "b1.", "b.", "b-", "#\u0661:g", "o\u0661", "e.5\r\n", "n1", "n16", "n0", "n17", "#9:n2@5",
    "k0", "k1", "k2", "k-1", "k1.5", "#4:k1@9",
]


def command_vectors() -> dict:
    cases = []
    for text in COMMANDS:
        try:
            cmd = parse_command(text)
            cases.append({"text": text, "status": "ok", "kind": cmd.kind, "value": cmd.value,
                          "seq": cmd.seq, "host_ms": cmd.host_ms})
        except ProtocolError as error:
            cases.append({"text": text, "status": error.reason})
    return {"description": "command grammar of pendkit.device.commands: status is 'ok' or the error reason",
            "cases": cases}


def observation_vectors() -> dict:
    rng = np.random.default_rng(3)
    cases = []
    for k in range(12):
        obs = McuObservation(int(rng.integers(0, 2**31)), int(rng.integers(0, 1024)), int(rng.integers(150, 451)),
                             float(rng.normal(0, 1.5)), float(rng.normal(0, 30)), float(rng.normal(0, 200)),
                             frozenset(f for f, bit in (("arm_limit", k % 2), ("overspin", k % 3 == 0),
                                                        ("watchdog", k % 5 == 0)) if bit))
        cases.append({"millis": obs.millis, "position": obs.position_counts, "servo": obs.servo_counts,
                      "omega": obs.omega_rev_s, "accel": obs.acceleration_rev_s2,
                      "arm_velocity": obs.arm_velocity_counts_s,
                      "flags": obs.flag_bits, "obs_seq": k, "cmd_seq": 1000 + k, "echo_ms": 77 * k,
                      "v1": format_observation_v1(obs), "v2": format_observation_v2(obs, k, 1000 + k, 77 * k)})
    return {"description": "observation lines, v1 (S...) and v2 (R...), %.4f for omega/accel, %.1f arm velocity",
            "cases": cases}


def _scenarios(params: RigParams) -> dict[str, list[dict]]:
    def spin(start, step, count, t0):
        return [{"t": t0 + 25 * k, "frame": encode_ssi_frame((start + step * k) % 1024)} for k in range(count)]

    rng = np.random.default_rng(5)
    random_events = []
    t = 0
    for _ in range(300):
        t += int(rng.integers(1, 12))
        pick = rng.random()
        if pick < 0.3:
            random_events.append({"t": t, "cmd": str(rng.choice(["a", "s", "d", "f", "g", "h", "b0.3", "b-0.7",
                                                                 "e0.5", "e0", "p0", "p2", "bogus", "o10"]))})
        elif pick < 0.65:
            random_events.append({"t": t, "act": True})
        elif pick < 0.95:
            random_events.append({"t": t, "frame": encode_ssi_frame(int(rng.integers(0, 1024)))})
        else:
            random_events.append({"t": t, "frame": int(rng.integers(0, 1 << 16))})
    def acts(t0, n, period=10, resend=None):
        """n acting ticks; with `resend`, that command again every 100 ms as a live host would."""
        events = []
        for k in range(n):
            t = t0 + period * k
            if resend and k and (t - t0) % 100 == 0:
                events.append({"t": t, "cmd": resend})
            events.append({"t": t, "act": True})
        return events

    return {
        "discrete_to_the_limit": [{"t": 0, "cmd": "g"}, *acts(10, 40, resend="g"), {"t": 420, "cmd": "d"},
                                  *acts(430, 3)],
        "continuous_with_device_filter": [{"t": 0, "cmd": "e0.9"}, {"t": 1, "cmd": "b0.5"},
                                          *acts(10, 20, resend="h"), {"t": 215, "cmd": "b-1"}, *acts(220, 5)],
        "watchdog_holds_then_heartbeat": [{"t": 0, "cmd": "f"}, *acts(10, 25), {"t": 260, "cmd": "h"},
                                          *acts(270, 3)],
        "overspin_holds": [{"t": 0, "cmd": "g"}, *spin(0, 60, 8, 5), *[{"t": 210 + k, "cmd": c}
                                                                       for k, c in enumerate("gab")], *acts(220, 4),
                           {"t": 300, "cmd": "p0"}, *spin(480, 60, 2, 305), *acts(360, 2)],
        "bad_frames_make_stuck": [{"t": 0, "frame": encode_ssi_frame(100)},
                                  *[{"t": 25 * (k + 1), "frame": encode_ssi_frame(100, corrupt_parity=True)}
                                    for k in range(9)],
                                  {"t": 260, "cmd": "g"}, *acts(265, 2), *spin(101, 1, 2, 300)],
        "no_change_while_moving_is_stuck": [{"t": 0, "cmd": "g"},
                                            *[e for k in range(20) for e in ({"t": 25 * k + 1, "frame":
                                                                              encode_ssi_frame(200)},
                                                                             {"t": 25 * k + 2, "cmd": "g"},
                                                                             {"t": 25 * k + 5, "act": True},
                                                                             {"t": 25 * k + 15, "act": True})]],
        "offset_and_commands_rejected": [{"t": 0, "cmd": "o317"}, {"t": 1, "frame": encode_ssi_frame(317)},
                                         {"t": 26, "frame": encode_ssi_frame(320)}, {"t": 30, "cmd": "b7"},
                                         {"t": 31, "cmd": "#x:g"}, {"t": 32, "act": True}],
        "velocity_window_shortened": [*spin(0, 8, 6, 0), {"t": 140, "cmd": "n1"}, *spin(48, 8, 3, 150),
                                      {"t": 230, "cmd": "n2"}, *spin(72, -8, 4, 250)],
        "random_mix": random_events,
    }


def run_scenario(events: list[dict], params: RigParams) -> list[dict]:
    """Replay events on the Python device; the expected result of each."""
    mcu = McuLogic(params)
    results = []
    for event in events:
        t = event["t"]
        if "cmd" in event:
            try:
                mcu.apply(parse_command(event["cmd"]), t)
                results.append({"status": "ok"})
            except ProtocolError as error:
                results.append({"status": error.reason})
        elif "act" in event:
            counts = mcu.acting_tick(t)
            results.append({"servo": counts, "flags": sum(1 << i for i, f in enumerate(
                ("arm_limit", "overspin", "stuck_encoder", "watchdog")) if f in mcu.flags)})
        else:
            obs = mcu.streaming_frame(event["frame"], t)
            results.append({"position": obs.position_counts, "servo": obs.servo_counts, "omega": obs.omega_rev_s,
                            "accel": obs.acceleration_rev_s2, "arm_velocity": obs.arm_velocity_counts_s,
                            "flags": obs.flag_bits})
    return results


def device_vectors() -> dict:
    params = RigParams()
    scenarios = _scenarios(params)
    return {"description": "device logic: each event's expected result on a fresh device with the default "
                           "RigParams; act -> servo counts and flag bits (arm_limit 1, overspin 2, "
                           "stuck_encoder 4, watchdog 8); frame -> the observation (frame_error 16)",
            "servo_start": round_half_up(params.servo_centre_counts), "tolerance": 1e-9,
            "scenarios": [{"name": name, "events": events, "expected": run_scenario(events, params)}
                          for name, events in scenarios.items()]}


def build() -> dict[str, dict]:
    return {"commands.json": command_vectors(), "observations.json": observation_vectors(),
            "device.json": device_vectors(), "scheduler.json": scheduler_vectors()}


if __name__ == "__main__":
    for filename, content in build().items():
        (HERE / filename).write_text(json.dumps(content, indent=1) + "\n")
        print(f"wrote {HERE / filename}")
