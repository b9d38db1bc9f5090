"""The kit's controllers on the laptop and on the device: the same designs, the realistic twin and a virtual
rig over a real broker, the classroom's and a busy room's WiFi. One line a row:

    where=host|device controller=NAME network=NAME backend=twin|virtual-rig solved=K/N median_upright_s=X

Controllers: the energy swing-up + LQR, the minimum-time plan (both designed for where they run), and the
shipped `r-dqn-realistic` policy (the device makes its inputs from its own readings). "solved" is the kit's
rule (within 0.3 rad of upright for the last 200 of 500 steps); the time to upright
is the start of the final upright run. Twin rows start from the authors' random starts (seeds 10 000 on);
the virtual rig cannot be put in a random state (nor can a real one), so its rows start from a pendulum
hanging still, after the arm is held until it settles. On the device the laptop only sends heartbeats;
the time on the virtual rig runs `--speed` times faster than real time (the device's controller does
not depend on the laptop keeping up; laptop-side rows on a virtual rig run in real time, 30 s a start).

    python benchmarks/bench_on_device.py [--starts 20] [--networks classroom-wifi poor-wifi]
        [--controllers energy trajopt r-dqn] [--backends twin virtual-rig] [--where host device]
        [--rig-starts 5] [--speed 5]
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

import pendkit
from pendkit.agents.runs import Evaluation, judged_episodes
from pendkit.deploy.on_twin import onboard_episode, upload_to_twin
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack
from pendkit.network import IMPAIRMENTS
from pendkit.sim.fidelity import FIDELITY_PRESETS

SEED = 10_000
STEPS = 500
CONTROLLERS = ("energy", "trajopt", "r-dqn")  # r-dqn: the shipped r-dqn-realistic policy


def shipped_agent(env):
    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.runs import build_run

    spec, state = policy_weights("r-dqn-realistic")
    _, agent, inputs = build_run(spec, env)
    agent.load_policy(state)
    return agent, inputs


def blob_for(controller: str, params, env=None) -> bytes:
    """The controller as the device takes it."""
    if controller == "r-dqn":
        from pendkit.deploy.export import policy_blob

        agent, _ = shipped_agent(env)
        return pack(policy_blob(agent, params))
    return pack(design_swing_up(params, controller))


def twin_env(network: str, controller: str = "energy"):
    fidelity = dataclasses.replace(FIDELITY_PRESETS["realistic"], network=IMPAIRMENTS[network])
    if controller == "r-dqn":
        return pendkit.make(fidelity=fidelity, action_mode="discrete")
    return pendkit.make(fidelity=fidelity, action_mode="continuous", filter_coefficient=0.0)


def judged(episodes: list[list[float]], dt_s: float) -> Evaluation:
    return judged_episodes(episodes, dt_s)


def twin_row(where: str, controller: str, network: str, starts: int) -> Evaluation:
    from pendkit.adapt.routes import classical_on_env

    env = twin_env(network, controller)
    try:
        if where == "host" and controller == "r-dqn":
            from pendkit.agents.runs import evaluate_agent

            agent, inputs = shipped_agent(env)
            return evaluate_agent(env, agent, inputs, starts, SEED, "random")
        if where == "host":
            return classical_on_env(env, env, controller, starts, SEED, start="random")
        upload_to_twin(env, blob_for(controller, env.unwrapped.params, env))
        episodes = [onboard_episode(env, seed=SEED + k, start="random", steps=STEPS) for k in range(starts)]
        return judged(episodes, env.unwrapped.dt)
    finally:
        env.close()


def rig_row(where: str, controller: str, network: str, starts: int, speed: float) -> Evaluation:
    from pendkit.link.virtual_rig import LocalRig

    if where == "host":
        if controller == "r-dqn":
            raise SystemExit("laptop-side r-dqn rows on a virtual rig: use pendkit eval --policy r-dqn-realistic "
                             "--backend rig (docs/rl.md)")
        rig = LocalRig(impairment=network)
        try:
            from pendkit.adapt.routes import classical_on_env

            design = twin_env(network)
            env = pendkit.make(backend="rig", broker=rig.url, rig=rig.rig, action_mode="continuous",
                               filter_coefficient=0.0)
            outcome = classical_on_env(design, env, controller, starts, SEED)
            env.close()
            design.close()
            return outcome
        finally:
            rig.stop()
    return device_on_virtual_rig(controller, network, starts, speed)


def device_on_virtual_rig(controller: str, network: str, starts: int, speed: float) -> Evaluation:
    from pendkit.deploy.on_rig import RigSession, device_episode, upload_to_rig
    from pendkit.link.driver import RigLink
    from pendkit.link.virtual_rig import LocalRig

    rig = LocalRig(impairment=network, speed=speed)
    link = RigLink(rig.rig, rig.url)
    link.connect()
    session = RigSession(link)
    dt_s = rig.virtual.params.control_step_ms / 1000
    try:
        design = twin_env(network, controller)
        upload_to_rig(session, blob_for(controller, rig.virtual.params, design))
        design.close()
        episodes = [device_episode(session, STEPS, dt_s, speed) for _ in range(starts)]
        return judged(episodes, dt_s)
    finally:
        link.close()
        rig.stop()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--starts", type=int, default=20, help="random starts per twin row")
    parser.add_argument("--rig-starts", type=int, default=5, help="starts (from rest) per virtual-rig row")
    parser.add_argument("--networks", nargs="+", default=["classroom-wifi", "poor-wifi"], choices=sorted(IMPAIRMENTS))
    parser.add_argument("--controllers", nargs="+", default=list(CONTROLLERS), choices=CONTROLLERS)
    parser.add_argument("--backends", nargs="+", default=["twin", "virtual-rig"], choices=["twin", "virtual-rig"])
    parser.add_argument("--where", nargs="+", default=["host", "device"], choices=["host", "device"])
    parser.add_argument("--speed", type=float, default=5.0, help="virtual rig time per wall second (device rows)")
    args = parser.parse_args()
    for backend in args.backends:
        for network in args.networks:
            for controller in args.controllers:
                for where in args.where:
                    started = time.perf_counter()
                    if backend == "twin":
                        outcome = twin_row(where, controller, network, args.starts)
                    else:
                        outcome = rig_row(where, controller, network, args.rig_starts, args.speed)
                    held = outcome.min_held_fraction
                    print(f"where={where} controller={controller} network={network} backend={backend} "
                          f"{outcome.summary()} min_held={'-' if held is None else f'{held:.3f}'} "
                          f"wall_s={time.perf_counter() - started:.0f}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    np.set_printoptions(precision=3)
    main()
