"""Vectors for the device's own controllers, replayed by the firmware's C++ tests and by pytest:

- swing-up-energy/-trajopt.pkcb: the kit's designs for the default rig; .pktv: every acting tick's inputs
  (pendulum angle from the bottom, target in force) and the Python runtime's output (target, mode index)
  while that controller drove the realistic twin on poor WiFi (episodes from rest and random starts);
- uploads.json: upload scenarios (chunks as hex) and the device's controller status after each chunk;
- r-dqn-realistic-policy.pkcb: the shipped R-DQN as a policy the device runs (kind 4); policy-device.json:
  every decision while it drove the twin's device on poor WiFi: the newest reading, the time, the inputs
  the device made from it and the action the network chose;
- r-td3-bank-robust-policy.pkcb: the shipped R-TD3 with its bank of 13 observers (policy layout 2);
  observed-policy-device.json: every decision while it drove the twin's device: the newest reading, the
  time, the inputs the device made (its observers' estimate, the reading, its last action) and the target.

Run `python -m tests.vectors.make_onboard_vectors` (from the repository root) after a deliberate change;
`... make_onboard_vectors observed` remakes the layout-2 policy's alone.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from pendkit.deploy.export import VECTOR_HEADER, VECTORS_MAGIC
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import DenseLayer, NetworkBlob, pack
from pendkit.device.onboard import CHUNK_HEADER, CHUNK_MAGIC, OnboardController, blob_chunks
from pendkit.device.swingup_runtime import MODES

HERE = Path(__file__).parent
STATUS_KEYS = ("kind", "bytes", "crc", "running", "received", "total", "accepted", "refused", "ignored_chunks")
TICKS = 6000


class _Recording:
    """The runtime with every tick's inputs and outputs kept."""

    def __init__(self, runtime, rows: list) -> None:
        self.runtime, self.rows, self._start = runtime, rows, False

    def reset(self, pendulum_rad: float, target_rad: float) -> None:
        self.runtime.reset(pendulum_rad, target_rad)
        self.rows.append([2.0, pendulum_rad, target_rad, 0.0, 0.0])  # a start: its own row

    def tick(self, pendulum_rad: float, target_in_force_rad: float) -> float:
        output = self.runtime.tick(pendulum_rad, target_in_force_rad)
        self.rows.append([0.0, pendulum_rad, target_in_force_rad, output, MODES.index(self.runtime.mode)])
        return output


def record_swing_up(controller: str, ticks: int = TICKS, seed: int = 0) -> tuple[bytes, np.ndarray]:
    import pendkit
    from pendkit.deploy.on_twin import onboard_episode, upload_to_twin
    from pendkit.network import IMPAIRMENTS
    from pendkit.sim.fidelity import FIDELITY_PRESETS

    fidelity = dataclasses.replace(FIDELITY_PRESETS["realistic"], network=IMPAIRMENTS["poor-wifi"])
    env = pendkit.make(fidelity=fidelity, action_mode="continuous")
    blob = pack(design_swing_up(env.unwrapped.params, controller))
    upload_to_twin(env, blob)
    onboard = env.unwrapped.backend.device.mcu.onboard
    rows: list = []
    onboard.runtime = _Recording(onboard.runtime, rows)
    episode = 0
    while len(rows) < ticks:
        onboard_episode(env, seed=seed + episode, start="random" if episode % 2 else "rest", steps=150)
        episode += 1
    env.close()
    return blob, np.array(rows[:ticks], dtype=np.float32)


def _reading(observation) -> list:
    return [observation.millis, observation.position_counts, observation.servo_counts, observation.omega_rev_s,
            observation.acceleration_rev_s2, observation.arm_velocity_counts_s]


def _record_episodes(env, runtime, rows: list, decisions: int, seed: int, steps: int) -> None:
    """Run the uploaded policy's episodes (rest, random, ...) until `rows` holds `decisions`, marking each start."""
    from pendkit.deploy.on_twin import onboard_episode

    reset = runtime.reset

    def recording_reset(*args):
        reset(*args)
        rows.append({"start": True})

    runtime.reset = recording_reset
    episode = 0
    while len(rows) < decisions:
        onboard_episode(env, seed=seed + episode, start="random" if episode % 2 else "rest", steps=steps)
        episode += 1


def record_policy(decisions: int = 1000, seed: int = 0) -> tuple[bytes, list[dict]]:
    import pendkit
    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.runs import build_run
    from pendkit.deploy.export import policy_blob
    from pendkit.deploy.on_twin import upload_to_twin
    from pendkit.network import IMPAIRMENTS
    from pendkit.sim.fidelity import FIDELITY_PRESETS

    spec, state = policy_weights("r-dqn-realistic")
    fidelity = dataclasses.replace(FIDELITY_PRESETS["realistic"], network=IMPAIRMENTS["poor-wifi"])
    env = pendkit.make(fidelity=fidelity, action_mode="discrete")
    _, agent, _ = build_run(spec, env)
    agent.load_policy(state)
    blob = pack(policy_blob(agent, env.unwrapped.params))
    upload_to_twin(env, blob)
    runtime = env.unwrapped.backend.device.mcu.onboard.runtime
    rows: list[dict] = []
    decide = runtime.tick

    def recording_tick(observation, now_ms):
        deciding = runtime.tick_count + 1 >= runtime.ticks_per_step and observation is not None
        inputs = runtime.inputs(observation, now_ms) if deciding else None
        action = decide(observation, now_ms)
        if action is not None:
            rows.append({"reading": _reading(observation), "now_ms": int(now_ms),
                         "inputs": [float(v) for v in inputs], "action": action})
        return action

    runtime.tick = recording_tick
    _record_episodes(env, runtime, rows, decisions, seed, steps=250)
    env.close()
    return blob, rows[:decisions]


def record_observed_policy(decisions: int = 600, seed: int = 0) -> tuple[bytes, list[dict]]:
    import pendkit
    from pendkit.agents.pretrained import policy_weights
    from pendkit.deploy.learned_blob import learned_policy_blob
    from pendkit.deploy.on_twin import upload_to_twin

    blob = pack(learned_policy_blob(*policy_weights("r-td3-bank-robust")))
    env = pendkit.make(fidelity="realistic", action_mode="continuous")
    upload_to_twin(env, blob)
    runtime = env.unwrapped.backend.device.mcu.onboard.runtime
    rows: list[dict] = []
    decide, make_inputs = runtime.tick, runtime.inputs
    made = {}

    def recording_inputs(observation, now_ms):
        made["inputs"] = make_inputs(observation, now_ms)
        return made["inputs"]

    def recording_tick(observation, now_ms):
        target = decide(observation, now_ms)
        if target is not None:
            rows.append({"reading": _reading(observation), "now_ms": int(now_ms),
                         "inputs": [float(v) for v in made["inputs"]], "action": runtime.action,
                         "target_unit": target,
                         "observer": runtime.bank.chosen})
        return target

    runtime.tick, runtime.inputs = recording_tick, recording_inputs
    _record_episodes(env, runtime, rows, decisions, seed, steps=200)
    env.close()
    return blob, rows[:decisions]


def write_observed_policy() -> None:
    blob, rows = record_observed_policy()
    (HERE / "r-td3-bank-robust-policy.pkcb").write_bytes(blob)
    (HERE / "observed-policy-device.json").write_text(json.dumps({"description": "see make_onboard_vectors.py",
                                                                  "decisions": rows}) + "\n")
    print(f"wrote the observed policy: {len(blob)} bytes, {len(rows)} decisions")


def upload_scenarios() -> list[dict]:
    blob = pack(design_swing_up(None, "trajopt"))
    chunks = blob_chunks(blob, chunk_bytes=256)
    damaged = bytearray(blob)
    damaged[40] ^= 0x01
    tiny = NetworkBlob(np.zeros(2, np.float32), np.ones(2, np.float32), 5.0,
                       [DenseLayer(np.ones((3, 2), np.float32), np.zeros(3, np.float32))])
    oversized = CHUNK_HEADER.pack(CHUNK_MAGIC, 0, 70_000) + bytes(64)
    scenarios = {
        "whole, in order": chunks,
        "a lost chunk, then resumed from the device's count": [chunks[0], chunks[2], chunks[1], *chunks[2:]],
        "damaged (CRC)": blob_chunks(bytes(damaged), chunk_bytes=256),
        "oversized": [oversized],
        "a network (not run on the device)": blob_chunks(pack(tiny), chunk_bytes=256),
        "garbage and a chunk past the end": [b"PKUP", b"hello", CHUNK_HEADER.pack(CHUNK_MAGIC, 0, 10) + bytes(20)],
        "a second upload replaces the first": chunks + chunks,
        "a restart at offset 0 drops the partial one": chunks[:2] + chunks,
        **physical_range_scenarios(),
    }
    out = []
    for name, sequence in scenarios.items():
        device = OnboardController()
        statuses = []
        for chunk in sequence:
            device.chunk(chunk)
            statuses.append({key: device.status()[key] for key in STATUS_KEYS})
        out.append({"name": name, "chunks": [chunk.hex() for chunk in sequence], "status_after": statuses})
    return out


def observed_blob(changes: dict[str, float] | None = None):
    """A small layout-2 policy (no GRU, one tanh layer of zeros) whose one observer is the kit's rig with
    `changes` to its model (MODEL_FIELDS' names)."""
    from pendkit.deploy.export import observer_section
    from pendkit.device.observer_blob import MODEL_FIELDS
    from pendkit.device.policy_blob import PolicyBlob
    from pendkit.rig import RigParams

    params = RigParams()
    section = observer_section([params], params, 0.85)
    models = section.models.copy()
    for name, value in (changes or {}).items():
        models[:, MODEL_FIELDS.index(name)] = value
    network = NetworkBlob(np.zeros(15, np.float32), np.ones(15, np.float32), 5.0,
                          [DenseLayer(np.zeros((1, 15), np.float32), np.zeros(1, np.float32), "tanh")], None,
                          "continuous")
    return PolicyBlob(network, params.control_step_ms / 1000, params.acting_period_ms / 1000, 1, 2,
                      dataclasses.replace(section, models=models))


def physical_range_scenarios() -> dict[str, list[bytes]]:
    """Blobs whose rig parameters no rig has, refused by both parsers (pendkit.device.physical_ranges), beside
    the same blob with the kit's own rig, accepted."""
    swing_up = design_swing_up(None, "energy")
    stiff = dataclasses.replace(swing_up, scalars={**swing_up.scalars, "servo_kp_per_inertia": 1e30})
    return {"an observer of the kit's rig": blob_chunks(pack(observed_blob())),
            "an observer of a 1e-38 kg m^2 pendulum": blob_chunks(pack(observed_blob(
                {"pendulum_inertia_kg_m2": 1e-38}))),
            "an observer whose mass matrix no rigid body has": blob_chunks(pack(observed_blob(
                {"coupling_kg_m2": 0.0075}))),
            "a swing-up of servo gain 1e30 per unit of inertia": blob_chunks(pack(stiff))}


def write_pktv(path: Path, rows: np.ndarray) -> None:
    path.write_bytes(VECTOR_HEADER.pack(VECTORS_MAGIC, len(rows), 2, 2) + rows.astype("<f4").tobytes())


def main() -> None:
    for controller in ("energy", "trajopt"):
        blob, rows = record_swing_up(controller)
        (HERE / f"swing-up-{controller}.pkcb").write_bytes(blob)
        write_pktv(HERE / f"swing-up-{controller}.pktv", rows)
        print(f"wrote swing-up-{controller}: {len(blob)} bytes, {len(rows)} ticks")
    blob, rows = record_policy()
    (HERE / "r-dqn-realistic-policy.pkcb").write_bytes(blob)
    (HERE / "policy-device.json").write_text(json.dumps({"description": "see make_onboard_vectors.py",
                                                         "decisions": rows}) + "\n")
    print(f"wrote the policy: {len(blob)} bytes, {len(rows)} decisions")
    (HERE / "uploads.json").write_text(json.dumps({"description": __doc__.split("\n\n")[0],
                                                   "scenarios": upload_scenarios()}, indent=1) + "\n")
    print("wrote uploads.json")
    write_observed_policy()


if __name__ == "__main__":
    import sys

    write_observed_policy() if sys.argv[1:] == ["observed"] else main()
