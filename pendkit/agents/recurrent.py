"""The GRU trunk the trained recurrent agents share (R-DQN, R-TD3): one step at a time while acting,
whole re-encoded stretches while learning."""

from __future__ import annotations

import torch
from torch import nn

from pendkit.agents.threads import use_kit_threads


class GruTrunk(nn.Module):
    """A GRU over normalised step inputs. `features(x, h)` = [x, h] is what the heads see."""

    def __init__(self, input_dim: int, gru_size: int) -> None:
        super().__init__()
        use_kit_threads()
        self.gru = nn.GRU(input_dim, gru_size, batch_first=True)
        self.input_dim, self.gru_size = input_dim, gru_size

    def step(self, inputs: torch.Tensor, hidden: torch.Tensor) -> torch.Tensor:
        """One GRU step for a batch of inputs (batch, in) from states (batch, gru): the cell function on
        the GRU's own weights (a one-step nn.GRU call costs several times more on a CPU)."""
        g = self.gru
        return torch.gru_cell(inputs, hidden, g.weight_ih_l0, g.weight_hh_l0, g.bias_ih_l0, g.bias_hh_l0)

    def step_all(self, inputs: torch.Tensor, hidden: torch.Tensor) -> torch.Tensor:
        """One step from every (batch, steps) position at once: (batch, steps, gru)."""
        flat = self.step(inputs.reshape(-1, inputs.shape[-1]), hidden.reshape(-1, hidden.shape[-1]))
        return flat.reshape(*hidden.shape)

    def unroll(self, inputs: torch.Tensor, hidden: torch.Tensor, starts: torch.Tensor) -> torch.Tensor:
        """Hidden states after each step, (batch, steps, gru); at a `starts` step the stored state is taken.
        Stored states are taken rarely (episode starts inside a stretch), so the time axis is cut only at
        those steps and each piece runs through the fused GRU."""
        cuts = [0] + [t for t in range(1, inputs.shape[1]) if bool(starts[:, t].any())] + [inputs.shape[1]]
        h, pieces = hidden[:, 0], []
        for begin, end in zip(cuts[:-1], cuts[1:]):
            if begin:
                h = torch.where(starts[:, begin:begin + 1], hidden[:, begin], h)
            out, last = self.gru(inputs[:, begin:end], h.unsqueeze(0).contiguous())
            pieces.append(out)
            h = last[0]
        return torch.cat(pieces, dim=1)

    def warm_start(self, inputs: torch.Tensor, hidden: torch.Tensor, starts: torch.Tensor, burn_in: int):
        """(state to start the trained steps from, no gradient): the stored state after the burn-in."""
        start = hidden[:, burn_in].clone()
        if burn_in:
            with torch.no_grad():
                warm = self.unroll(inputs[:, :burn_in], hidden[:, :burn_in], starts[:, :burn_in])[:, -1]
            start = torch.where(starts[:, burn_in:burn_in + 1], start, warm)
        return start
