"""Upload a controller to the realistic twin's device and run episodes with it, through the twin's network
(latency and losses), as `pendkit deploy` does with a rig over MQTT."""

from __future__ import annotations

from pendkit.deploy.learned_blob import learned_policy_blob
from pendkit.device.controller_blob import pack
from pendkit.device.onboard import blob_chunks
from pendkit.episode import episode_limit
from pendkit.errors import PendkitError
from pendkit.features import angle_from_upright_rad

# pendkit modules that load MuJoCo are imported inside the functions that use them: importing this module does not
# need them (start-up).

SETTLE_STEPS = 3  # env steps for the last chunk to arrive before the status is read


class DeployError(PendkitError):
    """The rig refused the controller, or never got all of it."""


def _status(backend) -> dict:
    return backend.device.scheduler.status()["controller"]


def upload_to_twin(env, blob: bytes, rounds: int = 20) -> int:
    """Reset `env` (a realistic twin) and send `blob` in chunks, resuming from where the device got to
    after a lost one; the chunks sent. `DeployError` when the device refuses it (the reason is the
    device's) or it never arrives whole."""
    backend = env.unwrapped.backend
    if getattr(backend, "device", None) is None:
        raise DeployError("this env has no device to upload to: use the realistic twin")
    env.reset(options={"start": "rest"})
    before = _status(backend)
    start, sent = 0, 0
    for _ in range(rounds):
        for chunk in blob_chunks(blob, start):
            backend.send(chunk)
            sent += 1
        for _ in range(SETTLE_STEPS):
            backend.step_with_message("h")
        status = _status(backend)
        if status["refused"] > before["refused"]:
            raise DeployError(f"the rig refused the controller: {status['last_refusal']}")
        if status["accepted"] > before["accepted"]:
            return sent
        start = status["received"] if status["total"] == len(blob) else 0
    raise DeployError(f"the controller did not arrive whole after {rounds} rounds ({sent} chunks sent)")


def onboard_episode(env, seed: int | None = None, start: str = "random", steps: int | None = None) -> list[float]:
    """Reset, start the device's controller (`k1`, sent again until the device says it runs) and send only
    heartbeats; the pendulum's angle from upright at every step as the host receives it."""

    base = env.unwrapped
    backend = base.backend
    _, info = env.reset(seed=seed, options={"start": start})
    angles = [angle_from_upright_rad(info["state"])]
    # not `run_episode`: the device's controller acts, so the host sends heartbeats below the env's actions
    for _ in range(steps or episode_limit(env)):
        message = "h" if _status(backend)["running"] else "k1"
        state = backend.step_with_message(message)
        angles.append(angle_from_upright_rad(state))
    return angles


def blob_on_rigs(blob: bytes, rigs: dict, starts: int = 5, seed: int = 10_000, steps: int = 500, say=None) -> dict:
    """A controller blob uploaded to each rig's twin device (`rigs`: name -> `RandomRig`) and run from rest and
    `starts` random starts (seeds `seed`, `seed + 1`, ...): an `Evaluation` per rig. `say`: told each rig's line."""
    from pendkit.agents.rig_suite import rig_env
    from pendkit.agents.runs import judged_episodes

    outcomes = {}
    for name, rig in rigs.items():
        env = rig_env(rig, action_mode="continuous")
        upload_to_twin(env, blob)
        step_s = rig.params.control_step_ms / 1000
        outcome = judged_episodes([onboard_episode(env, seed=seed + k, start=start, steps=steps)
                                   for k, start in enumerate(["rest"] + ["random"] * starts)], step_s)
        env.close()
        outcomes[name] = outcome
        if say is not None:
            say(name, outcome)
    return outcomes


def policy_on_devices(spec, state: dict, rigs: dict, starts: int = 5) -> dict:
    """A trained policy (`spec`, its policy state) as its device blob, run on each rig's device from rest and
    `starts` random starts (`blob_on_rigs`)."""

    return blob_on_rigs(pack(learned_policy_blob(spec, state)), rigs, starts)
