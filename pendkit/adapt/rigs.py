"""The rigs `pendkit adapt` works on: a (virtual) rig over MQTT, or a twin from a parameter file for tests.
Each counts its own time: the rig reports the commands it received (status `busy_s`); the twin counts the
steps that reached it. Neither hands its parameters to the adaptation."""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import time

import gymnasium as gym

from pendkit.adapt.session import Rig
from pendkit.deploy.on_rig import RigSession, device_episode, upload_to_rig
from pendkit.deploy.on_twin import onboard_episode, upload_to_twin
from pendkit.device.commands import frame_command
from pendkit.env_name import EPISODE_STEPS
from pendkit.link import DEFAULT_BROKER
from pendkit.link.driver import RigLink
from pendkit.link.rig_backend import is_servo_counts_range
from pendkit.network import IMPAIRMENTS
from pendkit.rig import RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS

HELD_RESET_STOP_S = 0.5  # the reset's stop before an excitation episode's own hold (the stream's first readings)
DEVICE_SEED = 20_000  # the twin's first episode on its device (from rest; each draws the network's delays anew)


class _CountedSteps(gym.Wrapper):
    """Counts the commands that reached the twin (its rig time: one control step each)."""

    def __init__(self, env, counter: list[int]) -> None:
        super().__init__(env)
        self.counter = counter

    def step(self, action):
        result = self.env.step(action)
        self.counter[0] += 1
        return result


def twin_rig(params, impairment="classroom-wifi", residual_offset_counts: int = 0) -> Rig:
    """A hidden rig: the realistic twin of `params` behind the given network (a name of
    `pendkit.network.IMPAIRMENTS` or a NetworkImpairment), read through an encoder calibrated
    `residual_offset_counts` off."""
    import pendkit

    network = IMPAIRMENTS[impairment] if isinstance(impairment, str) else impairment
    steps, device_seeds, residual = [0], itertools.count(DEVICE_SEED), [residual_offset_counts]

    def make_env(stream: dict | None = None, held: bool = False, **env_kwargs):
        chosen = dataclasses.replace(params, **(stream or {}))  # a twin resets at rest: `held` changes nothing
        fidelity = FIDELITY_PRESETS["realistic"].replace(name="hidden-rig", network=network,
                                                         encoder_residual_offset_counts=residual[0])
        return _CountedSteps(pendkit.make(fidelity=fidelity, params=chosen, start="rest", **env_kwargs), steps)

    def recalibrate(shift_counts: int) -> None:
        residual[0] -= shift_counts  # the device's zero moved by the shift: a hanging pendulum reads that less

    def run_on_device(blob: bytes, episodes: int, episode_steps: int = EPISODE_STEPS) -> list[list[float]]:
        env = make_env(action_mode="continuous")
        upload_to_twin(env, blob)
        runs = [onboard_episode(env, seed=next(device_seeds), start="rest", steps=episode_steps)
                for _ in range(episodes)]
        steps[0] += sum(len(run) for run in runs)  # every step sent the rig a heartbeat
        env.close()
        return runs

    seconds = lambda: steps[0] * params.control_step_ms / 1000  # noqa: E731
    return Rig(make_env, seconds, name=f"twin ({impairment if isinstance(impairment, str) else 'own network'})",
               prior=lambda: configured_prior(params.servo_min_counts, params.servo_max_counts),
               run_on_device=run_on_device, recalibrate=recalibrate)


def configured_prior(min_counts: int, max_counts: int) -> RigParams:
    """The default rig flashed with these servo end counts (what a rig's status reports of its firmware)."""
    return dataclasses.replace(RigParams(), servo_min_counts=min_counts, servo_max_counts=max_counts)


def mqtt_rig(rig_id: str, broker: str | None, login=None) -> Rig:
    """A rig over MQTT; its time is what it reports having received (a rig that does not report it is
    measured from the host's first command to its last instead, and says so in the name). `login`: a
    `BrokerLogin` (username, password, TLS CA) for a classroom broker."""
    import pendkit

    login_options = login.rig_options() if login is not None else {}
    link_arguments = login.link_arguments() if login is not None else {}

    first: list[float] = []
    configured: list[RigParams] = []
    shift = [0]  # counts added to the prior's encoder offset (`recalibrate`)

    def prior() -> RigParams:
        if not configured:
            counts = rig_status(rig_id, broker, link_arguments=link_arguments).get("servo_counts_range")
            configured.append(configured_prior(*counts) if is_servo_counts_range(counts) else RigParams())
        return configured[0]

    def calibrated() -> RigParams:
        base = prior()
        return dataclasses.replace(base, encoder_offset_counts=(base.encoder_offset_counts + shift[0])
                                   % base.encoder_counts)

    def make_env(stream: dict | None = None, held: bool = False, **env_kwargs):
        if not first:
            first.append(time.monotonic())
        params = dataclasses.replace(calibrated(), **(stream or {}))  # the env sends its offset: o<counts>
        # `held`: the caller holds the arm until the pendulum hangs still (the excitation), quicker than the
        # reset's wait with the servo stopped, and less of the rig's time
        waiting = {"settle": False, "reset_stop_s": HELD_RESET_STOP_S} if held else {"settle": True}
        return pendkit.make(backend="rig", rig=rig_id, broker=broker, params=params,
                            rig_options={**waiting, **login_options}, **env_kwargs)

    def seconds() -> float:
        reported = rig_status(rig_id, broker, link_arguments=link_arguments).get("busy_s")
        if isinstance(reported, (int, float)) and not isinstance(reported, bool) and math.isfinite(reported) \
                and reported >= 0:
            return float(reported)
        return time.monotonic() - first[0] if first else 0.0

    def run_on_device(blob: bytes, episodes: int, episode_steps: int = EPISODE_STEPS) -> list[list[float]]:
        link = RigLink(rig_id, broker or DEFAULT_BROKER, **link_arguments)
        link.connect()
        try:
            session = RigSession(link)
            session.command(f"o{calibrated().encoder_offset_counts}")
            upload_to_rig(session, blob)
            step_s = prior().control_step_ms / 1000
            return [device_episode(session, episode_steps, step_s) for _ in range(episodes)]
        finally:
            link.close()

    def recalibrate(shift_counts: int) -> None:
        shift[0] += shift_counts

    return Rig(make_env, seconds, name=f"rig {rig_id}", prior=prior, run_on_device=run_on_device,
               recalibrate=recalibrate)


def rig_status(rig_id: str, broker: str | None, wait_s: float = 2.0, link_arguments: dict | None = None) -> dict:
    """The rig's status after asking it for a fresh one (command `r`); the retained one if no fresh one
    comes within `wait_s` (a v1 rig, or a device that is off)."""

    link = RigLink(rig_id, broker or DEFAULT_BROKER, **(link_arguments or {}))
    try:
        link.connect()
        link.publish(frame_command("r", 2, 1, int(time.monotonic() * 1000)))
        deadline = time.monotonic() + wait_s
        while time.monotonic() < deadline and not link.status_is_live:
            time.sleep(0.02)
        status = json.loads(link.status) if link.status else {}
        return status if isinstance(status, dict) else {}  # a forged or broken status says nothing
    except (ValueError, OSError):
        return {}
    finally:
        link.close()
