"""Study: how much excitation identification needs, and how many searches. For each hidden rig (the 6 of
`bench_transfer.py adapt`, seed 2027, each with its network and calibration error), record an excitation,
identify, and run the identified twin's minimum-time design on the hidden rig's own device (3 episodes from
rest, recalibrated as `pendkit adapt` does):

    python benchmarks/studies/excitation_length.py --episodes 6 --free-steps 90 --restarts 3
    python benchmarks/studies/excitation_length.py --episodes 3 --free-steps 90 --restarts 2 --evaluations 1200

One line per rig: rig time, identification seconds, the errors of the servo speed and the pendulum's natural
frequency, the servo loop's damping (identified/true), and the device's episodes solved.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def run(rig_name: str, hidden, episodes: int, free_steps: int, restarts: int, evaluations: int,
        device_episodes: int) -> str:
    from pendkit.adapt.excitation import EPISODES, Excitation, rest_offset_counts
    from pendkit.adapt.identify import identify_best
    from pendkit.adapt.recording_checks import record_checked
    from pendkit.adapt.rigs import twin_rig
    from pendkit.adapt.routes import judged
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack

    rig = twin_rig(hidden.params, hidden.network, hidden.residual_offset_counts)
    plan = [Excitation(*EPISODES[k % len(EPISODES)], free_steps=free_steps) for k in range(episodes)]
    recordings, prior, _ = record_checked(rig, plan)
    rig_s = rig.seconds()
    started = time.perf_counter()
    fit = identify_best(recordings, prior, evaluations, seeds=range(restarts))
    laptop_s = time.perf_counter() - started
    residual = rest_offset_counts(recordings, fit.params.encoder_counts)
    rig.recalibrate(residual)
    import dataclasses
    params = dataclasses.replace(fit.params, encoder_offset_counts=(fit.params.encoder_offset_counts + residual)
                                 % fit.params.encoder_counts)
    true = hidden.params
    solved = "-"
    if device_episodes:
        blob = pack(design_swing_up(params, "trajopt"))
        outcome = judged(rig.run_on_device(blob, device_episodes), true.control_step_ms / 1000)
        solved = f"{sum(outcome.solved)}/{device_episodes}"
    return (f"excitation rig={rig_name} episodes={episodes} free_steps={free_steps} restarts={restarts} "
            f"evaluations={evaluations} rig_s={rig_s:.1f} identify_s={laptop_s:.1f} "
            f"speed_error={params.servo_speed_s_per_60deg / true.servo_speed_s_per_60deg - 1:+.1%} "
            f"omega_error={params.pendulum_natural_frequency_rad_s / true.pendulum_natural_frequency_rad_s - 1:+.1%} "
            f"servo_damping={params.servo_damping_ratio:.2f}/{true.servo_damping_ratio:.2f} "
            f"cost={fit.cost:.2g} device_trajopt={solved}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--episodes", type=int, default=6)
    parser.add_argument("--free-steps", type=int, default=90)
    parser.add_argument("--restarts", type=int, default=3)
    parser.add_argument("--evaluations", type=int, default=1200)
    parser.add_argument("--device-episodes", type=int, default=3)
    parser.add_argument("--rigs", type=int, default=6)
    args = parser.parse_args()
    from pendkit.sim.randomize import held_out_rigs

    for k, hidden in enumerate(held_out_rigs(args.rigs, 2027)):
        print(run(f"hidden-{k:02d}", hidden, args.episodes, args.free_steps, args.restarts, args.evaluations,
                  args.device_episodes), flush=True)


if __name__ == "__main__":
    main()
