"""The env over a virtual rig over Mosquitto: step timing and observation age, 60 ms steps for 30 s.

The virtual rig runs in its own process (`pendkit virtual-rig`), as a real rig is its own device. Dropped
observations are gaps in the v2 observation sequence numbers. Goal: p99 step-period error at most 2 ms.

    python benchmarks/bench_rig_loop.py [--seconds 30]
"""

from __future__ import annotations

import argparse
import tempfile

import numpy as np

import pendkit
from pendkit.link.broker import MosquittoBroker
from pendkit.link.virtual_rig import virtual_rig_process


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=30.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as work, MosquittoBroker(work) as broker, \
            virtual_rig_process(broker.url, "r01"):
        env = pendkit.make(backend="rig", rig="r01", broker=broker.url,
                           rig_options={"reset_stop_s": 1.0})
        env.reset(seed=0)
        backend = env.unwrapped.backend
        dropped_before = backend.link.counters.dropped
        rng = np.random.default_rng(0)
        ages = []
        steps = int(args.seconds / env.unwrapped.dt)
        for _ in range(steps):
            _, _, _, _, info = env.step(int(rng.integers(0, 5)))
            ages.append(info["observation_age_s"])
        errors_ms = np.abs(np.array(backend.step_period_errors_s)) * 1000
        ages_ms = np.array(ages) * 1000
        counters = backend.link.counters
        dropped = counters.dropped - dropped_before
        env.close()
    print(f"steps={steps} observations_received={counters.received} malformed={counters.malformed}")
    print(f"step_period_error_p50_ms={np.percentile(errors_ms, 50):.3f} "
          f"step_period_error_p99_ms={np.percentile(errors_ms, 99):.3f} "
          f"obs_age_p50_ms={np.percentile(ages_ms, 50):.2f} obs_age_p99_ms={np.percentile(ages_ms, 99):.2f} "
          f"dropped={dropped}")


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
