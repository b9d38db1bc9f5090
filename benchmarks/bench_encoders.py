"""Why the fixed random GRU (the `r-dqn-reservoir` ablation) does not help: saturation and what a probe can
read from it. For several seeds: episodes of random actions on the realistic twin; the reservoir (32 units)
fed the raw step inputs, and fed inputs normalised with running statistics. Printed per setting:

    encoder=<raw|normalised> seed=<s> saturated_units=<fraction |h|>0.95> pinned_update_gates=<fraction z<0.05 or >0.95>
      probe_r2_input=<R^2> probe_r2_encoding=<R^2>

The probe is a ridge regression (held-out half) of the true present pendulum rate from what an agent two
steps late would see: the delayed input alone, or the delayed input joined to the reservoir's state.

    python benchmarks/bench_encoders.py --seeds 3
"""

from __future__ import annotations

import argparse

import numpy as np
import torch

import pendkit
from pendkit.agents.gru_encoder import GruEncoder
from pendkit.agents.inputs import StepInputs
from pendkit.agents.normalizer import RunningNormalizer

DELAY_STEPS = 2


def collect(seed: int, episodes: int = 6):
    env = pendkit.make(fidelity="realistic")
    inputs = StepInputs.for_env(env)
    rng = np.random.default_rng(seed)
    rows, truth = [], []
    for episode in range(episodes):
        observation, info = env.reset(seed=seed * 100 + episode)
        x, xs, ts = inputs.reset(observation), [], []
        for _ in range(500):
            action = int(rng.integers(5))
            observation, _, _, _, info = env.step(action)
            x = inputs.step(observation, action)
            xs.append(x)
            ts.append(info["true_state"]["pendulum_velocity_rad_s"])
        rows.append(np.array(xs))
        truth.append(np.array(ts))
    return rows, truth


def encode(rows, seed: int, normalise: bool):
    encoder = GruEncoder(rows[0].shape[1], 32, seed)
    norm = RunningNormalizer(rows[0].shape[1])
    for episode in rows:
        norm.update(episode)
    hidden, gates = [], []
    for episode in rows:
        encoder.reset()
        states = []
        for x in episode:
            z = norm.normalize(torch.as_tensor(x, dtype=torch.float32)).numpy() if normalise else x
            with torch.no_grad():
                gates.append(torch.sigmoid(encoder.cell.weight_ih[32:64] @ torch.as_tensor(z, dtype=torch.float32)
                                           + encoder.cell.bias_ih[32:64] + encoder.cell.weight_hh[32:64]
                                           @ encoder.hidden[0] + encoder.cell.bias_hh[32:64]).numpy())
            states.append(encoder.encode(z)[-32:])
        hidden.append(np.array(states))
    return hidden, np.array(gates)


def probe_r2(features: np.ndarray, target: np.ndarray) -> float:
    half = len(target) // 2
    mean, std = features[:half].mean(0), features[:half].std(0) + 1e-9
    design = np.c_[(features - mean) / std, np.ones(len(features))]
    weights = np.linalg.solve(design[:half].T @ design[:half] + 1e-3 * np.eye(design.shape[1]),
                              design[:half].T @ target[:half])
    residual = target[half:] - design[half:] @ weights
    return float(1 - residual.var() / target[half:].var())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args()
    torch.set_num_threads(1)
    for seed in range(args.seeds):
        rows, truth = collect(seed)
        delayed_input = np.concatenate([np.r_[np.repeat(e[:1], DELAY_STEPS, 0), e[:-DELAY_STEPS]] for e in rows])
        target = np.concatenate(truth)
        for normalise in (False, True):
            hidden, gates = encode(rows, seed, normalise)
            delayed_hidden = np.concatenate([np.r_[np.repeat(h[:1], DELAY_STEPS, 0), h[:-DELAY_STEPS]] for h in hidden])
            all_hidden = np.concatenate(hidden)
            print(f"encoder={'normalised' if normalise else 'raw'} seed={seed} "
                  f"saturated_units={np.mean(np.abs(all_hidden) > 0.95):.2f} "
                  f"pinned_update_gates={np.mean((gates < 0.05) | (gates > 0.95)):.2f} "
                  f"probe_r2_input={probe_r2(delayed_input, target):.3f} "
                  f"probe_r2_encoding={probe_r2(np.c_[delayed_input, delayed_hidden], target):.3f}", flush=True)


if __name__ == "__main__":
    from provenance import print_header  # benchmarks/provenance.py (here: tests load this file alone)

    print_header()
    main()
