"""Hidden tests for lab 08 (instructor material: never copied into labs/)."""

import numpy as np
import torch

from pendkit.grading import expect, task

gru = task("08.gru_step", function="gru_step", title="One step of a GRU cell")
delayed = task("08.delayed_view", function="delayed_view", title="What a delayed agent sees")


@gru.test(points=2, hidden=True, hint="It must agree with torch.nn.GRUCell, the cell pendkit's encoder uses.")
def matches_torch(fn, rng):
    cell = torch.nn.GRUCell(5, 6).double()
    x, h = rng.normal(size=5), rng.normal(size=6)
    with torch.no_grad():
        expected = cell(torch.tensor(x)[None], torch.tensor(h)[None])[0].numpy()
    weights = [p.detach().numpy() for p in (cell.weight_ih, cell.weight_hh, cell.bias_ih, cell.bias_hh)]
    expect(np.allclose(np.asarray(fn(x, h, *weights), dtype=float), expected), "differs from torch.nn.GRUCell")


@delayed.test(points=1, hidden=True, hint="A delay longer than the episode shows only the first observation.")
def longer_than_the_episode(fn, rng):
    observations = rng.normal(size=(4, 3))
    got = np.asarray(fn(observations, 10), dtype=float)
    expect(np.allclose(got, np.repeat(observations[:1], 4, axis=0)), "every row should be the first observation")
