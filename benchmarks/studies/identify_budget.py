"""Study: does identification pass the tests' criteria on half their budget (300 candidate rigs, not 600) with
a smaller population or a Sobol start? docs/results/test-suite.md.

    python benchmarks/studies/identify_budget.py --case hitec-hsb-9380th --evaluations 300 --members 20 \
        --start sobol --seeds 0 1 2

Cases: the two hidden rigs of `tests/adapt/test_identify_hidden_rigs.py` (host steps through classroom WiFi)
and `device-clock` (the HSB-9380TH through poor WiFi, `tests/adapt/test_replay.py`), each with that test's
recordings and criteria. The search is `pendkit.adapt.identify.identify`'s (differential evolution, then
Nelder-Mead on a quarter of the budget) with the population and its start as options; the kit's default
(70 members, uniform) is unchanged. One line per seed.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))


def case_recordings(case: str):
    """(hidden rig, prior, recordings) as the case's test makes them."""
    from pendkit.network import IMPAIRMENTS
    from pendkit.rig import RigParams
    from tests.adapt.test_adapt import recordings
    from tests.adapt.test_replay import logged_recordings

    if case == "device-clock":
        hidden = RigParams.preset("hitec-hsb-9380th").with_dowel_length(0.42)
        return hidden, RigParams(), logged_recordings(hidden, IMPAIRMENTS["poor-wifi"], tempfile.mkdtemp(), 6)
    hidden = RigParams.preset(case).with_dowel_length(0.42)
    found, rig = recordings(hidden, episodes=6, impairment="classroom-wifi")
    return hidden, rig.prior(), found


def search(recordings, prior, evaluations: int, members: int, start: str, seed: int):
    """`identify`'s two searches with `members` started `start` ("uniform" or "sobol"): (params, cost, prior cost)."""
    from scipy.optimize import differential_evolution, minimize
    from scipy.stats import qmc

    from pendkit.adapt import identify as kit
    from pendkit.adapt.replay import replay_cost

    replayed = kit.on_device_clock(recordings)
    cost = replay_cost if replayed else kit.matching_cost
    box = np.array(kit.search_box((0.0, prior.pwm_period_ms) if replayed else kit.SERVO_BOUNDS["latency_ms"]))
    pendulum = kit.fit_pendulum(recordings, prior)
    objective = lambda x: kit.guarded_cost(cost, *kit.candidate(pendulum, x), recordings)  # noqa: E731
    dims = len(box)
    unit = (qmc.Sobol(dims, seed=seed).random(members) if start == "sobol"
            else np.random.default_rng(seed).uniform(size=(members, dims)))
    population = box[:, 0] + unit * (box[:, 1] - box[:, 0])
    population[0] = [0.0] * (dims - 1) + [prior.pwm_period_ms / 2 if replayed else kit.PRIOR_LATENCY_MS]
    evolved = differential_evolution(objective, box, maxiter=max(1, 3 * evaluations // 4 // members - 1),
                                     init=population, seed=seed, polish=False, tol=1e-6, mutation=(0.5, 1.0),
                                     recombination=0.7)
    polished = minimize(objective, evolved.x, method="Nelder-Mead", bounds=box,
                        options={"maxfev": evaluations // 4, "xatol": 1e-3, "fatol": 1e-6})
    best = polished if polished.fun < evolved.fun else evolved
    params, last = kit.candidate(pendulum, best.x)
    return params, float(best.fun), float(cost(prior, last if replayed else kit.PRIOR_LATENCY_MS, recordings))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", choices=["mks-x5-hbl550", "hitec-hsb-9380th", "device-clock"], required=True)
    parser.add_argument("--evaluations", type=int, default=300)
    parser.add_argument("--members", type=int, default=20)
    parser.add_argument("--start", choices=["uniform", "sobol"], default="sobol")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    args = parser.parse_args()
    warnings.filterwarnings("ignore", message="The balance properties of Sobol")  # 20 or 35 points, not 2^k
    hidden, prior, recordings = case_recordings(args.case)
    for seed in args.seeds:
        started = time.process_time()
        params, cost, prior_cost = search(recordings, prior, args.evaluations, args.members, args.start, seed)
        speed = abs(params.servo_speed_s_per_60deg / hidden.servo_speed_s_per_60deg - 1)
        frequency = abs(params.pendulum_natural_frequency_rad_s / hidden.pendulum_natural_frequency_rad_s - 1)
        damping = abs(params.servo_damping_ratio - hidden.servo_damping_ratio)
        if args.case == "device-clock":
            passes = cost < prior_cost / 10 and speed <= 0.1 and frequency <= 0.03 and damping <= 0.15
        else:
            allowed = max(abs(prior.servo_damping_ratio - hidden.servo_damping_ratio) / 2, 0.1)
            passes = cost < prior_cost / 5 and speed <= 0.1 and frequency <= 0.05 and damping <= allowed
        print(f"identify-budget case={args.case} evaluations={args.evaluations} members={args.members} "
              f"start={args.start} seed={seed} passes={passes} cost_ratio={cost / prior_cost:.3f} "
              f"speed_off={speed:.3f} frequency_off={frequency:.3f} damping_off={damping:.3f} "
              f"cpu_s={time.process_time() - started:.0f}", flush=True)


if __name__ == "__main__":
    import os
    import runpy  # the header line every benchmark prints first (benchmarks/provenance.py)

    runpy.run_path(os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "provenance.py"),
                   run_name="__main__")
    main()
