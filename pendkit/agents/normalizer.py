"""Running input normalisation: mean and variance by Welford's method, kept in checkpoints.

Raw rig inputs span three orders of magnitude (a pendulum acceleration of 75 rad/s^2 beside an angle of
0.1 rad); a GRU fed those saturates. Normalised and clipped inputs keep its units in their working range.
"""

from __future__ import annotations

import numpy as np
import torch

CLIP_STD = 5.0  # normalised inputs beyond 5 standard deviations are outliers (a spin, a glitch): clipped


class RunningNormalizer:
    """`update(x)` with each new input; `normalize(x)` = clip((x - mean) / std, +-5). A dimension that never
    varies (a one-hot action never taken) keeps a std of 1, so it passes through centred."""

    def __init__(self, dim: int) -> None:
        self.count = 0
        self.mean = np.zeros(dim, dtype=np.float64)
        self._m2 = np.zeros(dim, dtype=np.float64)
        self._refresh()

    def update(self, x) -> None:
        x = np.asarray(x, dtype=np.float64).reshape(-1, self.mean.size)
        for row in x:  # Welford: stable for long runs, one row at a time as the actor produces them
            self.count += 1
            delta = row - self.mean
            self.mean += delta / self.count
            self._m2 += delta * (row - self.mean)
        self._refresh()

    def _refresh(self) -> None:
        variance = self._m2 / max(self.count - 1, 1)
        std = np.sqrt(variance)
        self.std = np.where(std > 1e-6, std, 1.0)
        self._mean_t = torch.as_tensor(self.mean, dtype=torch.float32)
        self._std_t = torch.as_tensor(self.std, dtype=torch.float32)

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        return ((x - self._mean_t) / self._std_t).clamp(-CLIP_STD, CLIP_STD)

    def state_dict(self) -> dict:
        return {"count": self.count, "mean": self.mean.copy(), "m2": self._m2.copy()}

    def load_state_dict(self, state: dict) -> None:
        self.count = int(state["count"])
        self.mean[...] = state["mean"]
        self._m2[...] = state["m2"]
        self._refresh()
