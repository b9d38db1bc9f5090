"""Study: does an LQR catch help `r-td3-bank-robust` hold more rigs when the rig's device runs it?

    python benchmarks/studies/device_lqr_catch.py [--rigs validation|unseen] [--catch-rad A --rate-rad-s W
                                                   --fall-rad F] [--weights RUN.pt] [--bank-size N]

The policy's blob runs on each rig's twin device as `bench_transfer.py device-policy` runs it (rest + 5 random
starts, 500 steps, no network between readings and targets). With a catch (`--catch-rad` > 0) every deciding
tick also looks at the estimate of the bank's chosen observer: inside the catch region (|angle from upright| <
A and |pendulum rate| < W) an LQR takes the target until the pendulum is more than F from upright. The LQR
is designed per bank candidate (its model, the device's delay, the rig's filter) and the chosen candidate's
gain is used, as a device that knows only its bank would. The network still steps and reads the LQR's action
as its own last one, so it takes over again where the LQR lets go. Choose on `--rigs validation`; judge once
on the unseen rigs. `--weights`: a bank policy's weights file (e.g. `robust_observer.py --out`) in place of the
shipped one; `--bank-size`: the device's observers designed for that many candidates (`observer_bank(N)`, the
first 13 those of training; the device takes at most 16). Results: docs/results/robust.md.
"""

from __future__ import annotations

import argparse

import numpy as np


def candidate_gains():
    """(gain over [arm, from upright, arm rate, pendulum rate, filtered target], filter) per bank candidate."""
    from pendkit.control.lqr import LqrBalancer
    from pendkit.sim.randomize import observer_bank
    from pendkit.timing import device_command_delay_s as device_delay_s

    balancers = [LqrBalancer(p, period_s=p.control_step_ms / 1000, delay_s=device_delay_s(p), internal_filter=True)
                 for p in observer_bank()]
    return [(b.gain.reshape(-1), b.filter_coefficient) for b in balancers]


def add_catch(runtime, gains, catch_rad: float, rate_rad_s: float, fall_rad: float) -> dict:
    """Wrap the device runtime's `tick` and `reset` with the catch; returns its counters."""
    from pendkit.encoder import angle_from_upright_rad

    decide, restart = runtime.tick, runtime.reset
    state = {"catching": False, "ticks": 0}
    range_rad = runtime.params.servo_range_rad

    def reset(*args):
        restart(*args)
        state["catching"] = False

    def tick(observation, now_ms):
        before = runtime.target_unit
        target = decide(observation, now_ms)
        if target is None:
            return None
        x = runtime.bank.observers[runtime.bank.chosen].x
        from_upright = angle_from_upright_rad(x[1])
        if not state["catching"]:
            state["catching"] = abs(from_upright) < catch_rad and abs(x[3]) < rate_rad_s
        elif abs(from_upright) > fall_rad:
            state["catching"] = False
        if not state["catching"]:
            return target
        state["ticks"] += 1
        gain, c = gains[runtime.bank.chosen]
        z = np.array([x[0], from_upright, x[2], x[3], before * range_rad])
        unit = float(np.clip(-(gain @ z) / range_rad, -1.0, 1.0))
        runtime.target_unit = c * before + (1 - c) * unit
        runtime.recent[0] = unit
        return runtime.target_unit

    runtime.tick, runtime.reset = tick, reset
    return state


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rigs", choices=["validation", "unseen"], default="validation")
    parser.add_argument("--catch-rad", type=float, default=0.0, help="0: the policy alone")
    parser.add_argument("--rate-rad-s", type=float, default=3.0)
    parser.add_argument("--fall-rad", type=float, default=0.8)
    parser.add_argument("--starts", type=int, default=5)
    parser.add_argument("--bank-size", type=int, default=None, help="candidates of the device's bank (default 13)")
    parser.add_argument("--weights", default=None, help="a weights file (default: r-td3-bank-robust as shipped)")
    args = parser.parse_args()

    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.rig_suite import preset_rigs, random_rigs, rig_env, validation_rigs
    from pendkit.agents.runs import SOLVED_TAIL_STEPS, load_weights
    from pendkit.deploy.learned_blob import learned_policy_blob
    from pendkit.deploy.on_twin import onboard_episode, upload_to_twin
    from pendkit.device.controller_blob import pack
    from pendkit.features import holds_upright
    from pendkit.sim.randomize import observer_bank

    spec, state = load_weights(args.weights) if args.weights else policy_weights("r-td3-bank-robust")
    blob = pack(learned_policy_blob(spec, state, observer=observer_bank(args.bank_size) if args.bank_size else None))
    gains = candidate_gains() if args.catch_rad > 0 else None
    rigs = validation_rigs(12) if args.rigs == "validation" else {**preset_rigs(), **random_rigs()}
    held_all = episodes = 0
    for name, rig in rigs.items():
        env = rig_env(rig, action_mode="continuous")
        upload_to_twin(env, blob)
        runtime = env.unwrapped.backend.device.mcu.onboard.runtime
        counters = add_catch(runtime, gains, args.catch_rad, args.rate_rad_s, args.fall_rad) \
            if args.catch_rad > 0 else {"ticks": 0}
        held = sum(holds_upright(onboard_episode(env, seed=10_000 + k, start=start, steps=500), SOLVED_TAIL_STEPS)
                   for k, start in enumerate(["rest"] + ["random"] * args.starts))
        env.close()
        print(f"lqr-catch rig={name} held={held}/{args.starts + 1} lqr_ticks={counters['ticks']}", flush=True)
        held_all, episodes = held_all + held, episodes + args.starts + 1
    print(f"lqr-catch rigs={args.rigs} catch_rad={args.catch_rad} rate_rad_s={args.rate_rad_s} "
          f"fall_rad={args.fall_rad} solved={held_all}/{episodes}")


if __name__ == "__main__":
    main()
