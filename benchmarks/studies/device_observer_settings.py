"""Study: what the device's bank of observers is designed for, chosen blind on fresh validation rigs.

    python benchmarks/studies/device_observer_settings.py [--validation-rigs 30] [--jobs 2] [--unseen]

`r-td3-bank-robust` as shipped, its observers designed for the device's own delays (a target reaches the servo
10 ms after its acting tick on average, a reading is the device's own) and a bank memory of 1 s. Each setting
below changes one of the three; every setting is scored on the devices of validation rigs drawn after the 12
the policy's checkpoint was kept by (rest + 5 random starts each), the best kept (a tie to the shipped one), and
with `--unseen` the kept one is run once on the devices of the presets and held-out rigs (90 episodes).
Results: docs/results/robust.md.
"""

from __future__ import annotations

import argparse
import dataclasses

# (command delay ms, reading delay ms, bank memory s): the shipped setting first
SETTINGS = ((10.0, 0.0, 1.0), (5.0, 0.0, 1.0), (15.0, 0.0, 1.0), (20.0, 0.0, 1.0), (30.0, 0.0, 1.0),
            (10.0, 5.0, 1.0), (10.0, 10.0, 1.0), (10.0, 0.0, 0.5), (10.0, 0.0, 2.0))


def blob_for(setting: tuple[float, float, float]) -> bytes:
    """The shipped bank policy's blob with its observers designed for `setting`."""
    from pendkit.agents.pretrained import policy_weights
    from pendkit.backend_contract import BackendTiming
    from pendkit.deploy.learned_blob import learned_policy_blob
    from pendkit.device.controller_blob import pack
    from pendkit.rig import RigParams

    command_ms, reading_ms, memory_s = setting
    spec, state = policy_weights("r-td3-bank-robust")
    step_s = RigParams().control_step_ms / 1000.0
    timing = BackendTiming(step_s, command_ms / 1000.0, reading_ms / 1000.0, firmware_readings=True)
    blob = learned_policy_blob(spec, state, timing=timing)
    forgetting = min(1.0, blob.period_s / memory_s)
    return pack(dataclasses.replace(blob, observers=dataclasses.replace(blob.observers, forgetting=forgetting)))


def held(setting: tuple[float, float, float], rigs: dict) -> dict:
    """Each rig's `Evaluation` with the setting's blob on its device."""
    from pendkit.agents.threads import use_kit_threads
    from pendkit.deploy.on_twin import blob_on_rigs

    use_kit_threads()
    return blob_on_rigs(blob_for(setting), rigs)


def choose_blind(settings: tuple, run, said, description: str) -> None:
    """Score every setting with `run(setting, rigs)` on the devices of fresh validation rigs, keep the best (a
    tie to the first, the shipped one) and with `--unseen` run the kept one on the presets and held-out rigs;
    `said(setting)` names a setting in the printed lines. Shared by the device studies."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--validation-rigs", type=int, default=30)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--unseen", action="store_true")
    args = parser.parse_args()

    from concurrent.futures import ProcessPoolExecutor

    from pendkit.agents.rig_suite import preset_rigs, random_rigs, summary, validation_rigs

    checking = validation_rigs(args.validation_rigs, after=12)
    with ProcessPoolExecutor(args.jobs) as pool:
        scores = {setting: summary(out)["solved"]
                  for setting, out in zip(settings, pool.map(run, settings, [checking] * len(settings)))}
    for setting, score in scores.items():
        print(f"{said(setting)}: device validation {score}/{6 * len(checking)}", flush=True)
    kept = max(settings, key=lambda s: (scores[s], s == settings[0]))
    print(f"kept: {said(kept)}", flush=True)
    if args.unseen:
        out = run(kept, {**preset_rigs(), **random_rigs(10)})
        print(f"kept setting: device, presets + held-out {summary(out)['solved']}/90 "
              + " ".join(f"{name}={sum(e.solved)}/{len(e.solved)}" for name, e in out.items()), flush=True)


def main() -> None:
    choose_blind(SETTINGS, held, lambda s: f"command {s[0]:g} ms, reading {s[1]:g} ms, memory {s[2]:g} s",
                 __doc__.splitlines()[0])


if __name__ == "__main__":
    import os
    import runpy  # the header line every benchmark prints first (benchmarks/provenance.py)

    runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "provenance.py"),
                   run_name="__main__")
    main()
