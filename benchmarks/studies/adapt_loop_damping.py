"""Study: does a shorter free swing lose an underdamped servo loop's damping, or only move which search seed
finds it? The two identification tests' cases (six excitation episodes; the HSB-9380TH's loop damping 0.2
against the prior's 0.7), three search seeds each, with the free swing at FREE_STEPS; the closest fit of the
three is what `pendkit adapt`'s restarts keep.

    python benchmarks/studies/adapt_loop_damping.py FREE_STEPS   # e.g. 90, then 78
"""

from __future__ import annotations

import dataclasses
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

CASES = (("classroom-wifi", "mks-x5-hbl550"), ("classroom-wifi", "hitec-hsb-9380th"),
         ("poor-wifi, device clock", "hitec-hsb-9380th"))


def recordings_for(case: tuple[str, str], free_steps: int, log_dir: str):
    from pendkit.adapt.excitation import EXCITATION_STREAM, Excitation, record, schedule
    from pendkit.adapt.rigs import twin_rig
    from pendkit.rig import RigParams

    network, preset = case
    hidden = RigParams.preset(preset).with_dowel_length(0.42)
    logged = network.startswith("poor-wifi")
    rig = twin_rig(hidden, "poor-wifi" if logged else network)
    extra = {"stream": EXCITATION_STREAM, "log_dir": log_dir} if logged else {}
    env = rig.make_env(**extra, **Excitation.env_kwargs())
    episodes = [dataclasses.replace(e, free_steps=free_steps) for e in schedule(6)]
    recordings = [record(env, e, seed=k) for k, e in enumerate(episodes)]
    env.close()
    prior = RigParams() if logged else rig.prior()
    return hidden, prior, recordings


def main() -> None:
    from pendkit.adapt.identify import identify

    free_steps = int(sys.argv[1])
    for case in CASES:
        with tempfile.TemporaryDirectory() as log_dir:
            hidden, prior, recordings = recordings_for(case, free_steps, log_dir)
            fits = []
            for seed in range(3):
                found = identify(recordings, prior, max_evaluations=600, seed=seed)
                fit = found.params
                fits.append((found.cost, seed, fit))
                omega = fit.pendulum_natural_frequency_rad_s / hidden.pendulum_natural_frequency_rad_s - 1
                print(f"free={free_steps} case={case[1]}/{case[0]} seed={seed} cost={found.cost:.4f} "
                      f"speed_error={fit.servo_speed_s_per_60deg / hidden.servo_speed_s_per_60deg - 1:+.1%} "
                      f"omega_error={omega:+.1%} "
                      f"loop_damping={fit.servo_damping_ratio:.2f} (true {hidden.servo_damping_ratio:.2f})", flush=True)
            cost, seed, fit = min(fits, key=lambda f: f[0])
            print(f"free={free_steps} case={case[1]}/{case[0]} closest=seed {seed} "
                  f"loop_damping={fit.servo_damping_ratio:.2f} (true {hidden.servo_damping_ratio:.2f})", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py

    print_header()
    main()
