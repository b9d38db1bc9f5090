"""Study: the device holds each target the bank policy decides for whole acting ticks before it takes effect.

    python benchmarks/studies/device_target_hold.py [--validation-rigs 30] [--jobs 2] [--unseen]

On the rig's device a target reaches the servo about 10 ms after it is decided (half a PWM frame), where in
training the twin's network put 15-34 ms between them. Held back one or two acting ticks (10 ms each), the
device's loop comes back inside what the policy was trained on; its observers are designed for the delay the
held targets then have. Every setting is scored on the devices of validation rigs drawn after the 12 the
policy's checkpoint was kept by (rest + 5 random starts each), the best kept (a tie to the shipped one), and
with `--unseen` the kept one runs once on the devices of the presets and held-out rigs (90 episodes). The
hold is this study's alone (the kit's device has none). Results: docs/results/robust.md.
"""

from __future__ import annotations

import argparse
import contextlib
from collections import deque

# (acting ticks each target is held, the command delay its observers are designed for, ms): shipped first
SETTINGS = ((0, 10.0), (1, 10.0), (1, 20.0), (2, 20.0), (2, 30.0))


@contextlib.contextmanager
def targets_held(ticks: int):
    """Devices installed inside this block hold each decided target `ticks` acting ticks."""
    import pendkit.device.observed_policy as observed

    shipped = observed.ObservedDevicePolicy

    class HeldTargets(shipped):
        def reset(self, *args) -> None:
            super().reset(*args)
            self.held, self.acting_ticks = deque(), 0

        def tick(self, observation, now_ms: float) -> float | None:
            self.acting_ticks += 1
            decided = super().tick(observation, now_ms)
            if decided is not None:
                self.held.append((self.acting_ticks + ticks, decided))
            released = None
            while self.held and self.held[0][0] <= self.acting_ticks:
                released = self.held.popleft()[1]
            return released

    observed.ObservedDevicePolicy = HeldTargets if ticks else shipped
    try:
        yield
    finally:
        observed.ObservedDevicePolicy = shipped


def blob_for(command_ms: float) -> bytes:
    """The shipped bank policy's blob, its observers designed for a command delay of `command_ms`."""
    from pendkit.agents.pretrained import policy_weights
    from pendkit.backend_contract import BackendTiming
    from pendkit.deploy.learned_blob import learned_policy_blob
    from pendkit.device.controller_blob import pack
    from pendkit.rig import RigParams

    spec, state = policy_weights("r-td3-bank-robust")
    timing = BackendTiming(RigParams().control_step_ms / 1000.0, command_ms / 1000.0, 0.0, firmware_readings=True)
    return pack(learned_policy_blob(spec, state, timing=timing))


def run(setting: tuple[int, float], rigs: dict) -> dict:
    """Each rig's `Evaluation` with `setting`'s blob on its device."""
    from pendkit.agents.threads import use_kit_threads
    from pendkit.deploy.on_twin import blob_on_rigs

    use_kit_threads()
    with targets_held(setting[0]):
        return blob_on_rigs(blob_for(setting[1]), rigs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--validation-rigs", type=int, default=30)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--unseen", action="store_true")
    args = parser.parse_args()

    from concurrent.futures import ProcessPoolExecutor

    from pendkit.agents.rig_suite import preset_rigs, random_rigs, summary, validation_rigs

    checking = validation_rigs(args.validation_rigs, after=12)
    with ProcessPoolExecutor(args.jobs) as pool:
        scores = {s: summary(out)["solved"] for s, out in zip(SETTINGS, pool.map(run, SETTINGS,
                                                                                  [checking] * len(SETTINGS)))}
    for (ticks, command_ms), score in scores.items():
        print(f"held {ticks} ticks, observers for {command_ms:g} ms: device validation {score}/{6 * len(checking)}",
              flush=True)
    kept = max(SETTINGS, key=lambda s: (scores[s], s == SETTINGS[0]))
    print(f"kept: held {kept[0]} ticks, observers for {kept[1]:g} ms", flush=True)
    if args.unseen:
        out = run(kept, {**preset_rigs(), **random_rigs(10)})
        print(f"kept setting: device, presets + held-out {summary(out)['solved']}/90 "
              + " ".join(f"{name}={sum(e.solved)}/{len(e.solved)}" for name, e in out.items()), flush=True)


if __name__ == "__main__":
    main()
