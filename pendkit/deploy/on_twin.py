"""Upload a controller to the realistic twin's device and run episodes with it, through the twin's network
(latency and losses), as `pendkit deploy` does with a rig over MQTT."""

from __future__ import annotations

from pendkit.device.onboard import blob_chunks
from pendkit.errors import PendkitError
from pendkit.features import angle_from_upright_rad

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
    from pendkit.episode import episode_limit

    base = env.unwrapped
    backend = base.backend
    _, info = env.reset(seed=seed, options={"start": start})
    angles = [angle_from_upright_rad(info["state"])]
    for _ in range(steps or episode_limit(env)):
        message = "h" if _status(backend)["running"] else "k1"
        state = backend.step_with_message(message)
        angles.append(angle_from_upright_rad(state))
    return angles
