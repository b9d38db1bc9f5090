"""Controllers as blobs for a rig to run: a trained R-DQN's network, an LQR's gain; and the shared test
vectors that hold the device runtimes (Python here, C++ in the firmware) to torch's outputs.

    python -m pendkit.deploy.export vectors tests/vectors   # rebuild the vectors from the shipped policy
"""

from __future__ import annotations

import struct
import sys
from pathlib import Path

import numpy as np

from pendkit.device.controller_blob import StateFeedbackBlob, pack
from pendkit.device.observer_blob import MODEL_FIELDS, ObserverSection
from pendkit.device.policy_blob import PolicyBlob
from pendkit.episode import run_episode
from pendkit.timing import device_timing

# pendkit modules that load MuJoCo, matplotlib and python-control are imported inside the functions that use them:
# importing this module does not need them (start-up).

VECTORS_MAGIC = b"PKTV"
VECTOR_HEADER = struct.Struct("<4sIHH")  # magic, steps, input size, output size


def policy_blob(agent, params):
    """A trained R-DQN as a policy the device runs itself: the network its agent provides
    (`device_network()`) and the inputs the device makes, one action per output."""

    network = agent.device_network()
    return PolicyBlob(network, params.control_step_ms / 1000.0, params.acting_period_ms / 1000.0,
                      int(network.layers[-1].weight.shape[0]))


def observer_section(candidates, params, filter_coefficient: float, actions_seen: int = 1, timing=None):
    """The observers of a layout-2 policy blob: each candidate rig's model and Kalman gain, designed for
    `timing` (default the device's own, `pendkit.timing.device_timing`)."""
    from pendkit.control.model import FurutaModel
    from pendkit.control.observer import DelayedAngleObserver
    from pendkit.control.observer_bank import DEFAULT_MEMORY_S

    timing, period_s = timing or device_timing(params), params.control_step_ms / 1000.0
    models, gains = [], []
    for rig in candidates:
        model = FurutaModel.from_rig(rig)
        observer = DelayedAngleObserver(model, period_s, timing.command_delay_s, timing.reading_delay_s)
        models.append([getattr(model, name) for name in MODEL_FIELDS])
        gains.append(observer.gain)
    return ObserverSection(np.array(models, np.float32), np.array(gains, np.float32), timing.command_delay_s,
                           timing.reading_delay_s, min(1.0, period_s / DEFAULT_MEMORY_S), filter_coefficient,
                           actions_seen)


def observed_policy_blob(agent, inputs, params, candidates, filter_coefficient: float, timing=None):
    """A trained R-TD3 reading the observers' estimate and the readings (`features="estimated+measured"`) as a
    policy the device runs itself (layout 2), its observers designed for `candidates` (RigParams: the rig,
    or a bank of them) on `timing` (default the device's); `params`: the rig it runs on."""

    candidates = candidates if isinstance(candidates, (tuple, list)) else (candidates,)
    return PolicyBlob(agent.device_network(), params.control_step_ms / 1000.0, params.acting_period_ms / 1000.0,
                      1, 2, observer_section(candidates, params, filter_coefficient, inputs.actions_seen, timing))


def state_feedback_blob(gain, reference, output_limit: float) -> StateFeedbackBlob:
    return StateFeedbackBlob(np.asarray(gain, dtype=np.float32).ravel(),
                             np.asarray(reference, dtype=np.float32).ravel(), float(output_limit))


def record_vectors(name: str = "r-dqn-realistic", steps: int = 10_000, seed: int = 0):
    """(blob, starts, inputs, torch outputs): a shipped policy driving its twin greedily, every step's raw
    input and the Q-values torch computes for it."""
    from pendkit.agents.policy_artifact import policy_artifact
    from pendkit.agents.runs import build_run

    artifact = policy_artifact(name=name)
    env, agent, inputs = build_run(artifact.spec)
    agent.load_policy(artifact.state)
    starts, xs, outputs = [], [], []
    episode = 0
    now = {}

    def recorded(observation, state):
        starts.append(now["first"])
        xs.append(np.asarray(now["x"], dtype=np.float32))
        q = agent.q_values(xs[-1])
        outputs.append(q.astype(np.float32))
        return int(np.argmax(q))

    def seen(action, observation, reward, terminated, truncated, info) -> None:
        now["x"], now["first"] = inputs.step(observation, action), False

    while len(xs) < steps:
        started = env.reset(seed=seed + episode, options={"start": "random" if episode % 2 else "rest"})
        agent.reset()
        now.update(x=inputs.reset(started[0]), first=True)
        run_episode(env, recorded, steps=min(500, steps - len(xs)), started=started, on_step=seen)
        episode += 1
    env.close()
    return agent.device_network(), np.array(starts), np.stack(xs), np.stack(outputs)


def write_vectors(folder: Path, name: str = "r-dqn-realistic") -> Path:
    blob, starts, xs, outputs = record_vectors(name)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{name}.pkcb").write_bytes(pack(blob))
    path = folder / f"{name}.pktv"
    rows = np.concatenate([starts[:, None].astype(np.float32), xs, outputs], axis=1).astype("<f4")
    path.write_bytes(VECTOR_HEADER.pack(VECTORS_MAGIC, len(xs), xs.shape[1], outputs.shape[1]) + rows.tobytes())
    return path


def read_vectors(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(episode starts, inputs, expected outputs) of a vectors file: per step, 1 + inputs + outputs float32."""
    data = Path(path).read_bytes()
    magic, steps, n_in, n_out = VECTOR_HEADER.unpack_from(data)
    if magic != VECTORS_MAGIC:
        raise ValueError(f"{path} is not a pendkit vectors file")
    rows = np.frombuffer(data, dtype="<f4", offset=VECTOR_HEADER.size).reshape(steps, 1 + n_in + n_out)
    return rows[:, 0] > 0.5, rows[:, 1:1 + n_in], rows[:, 1 + n_in:]


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] != "vectors":
        raise SystemExit("usage: python -m pendkit.deploy.export vectors FOLDER")
    print(f"wrote {write_vectors(Path(sys.argv[2]))}")
