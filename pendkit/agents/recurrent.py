"""What the trained recurrent agents share (R-DQN, R-TD3): the GRU trunk, one step at a time while acting
and whole re-encoded stretches while learning; the agent's episode state, replay and checkpoints around it;
and the network the device runs (`device_network`)."""

from __future__ import annotations

import copy

import numpy as np
import torch
from torch import nn

from pendkit.agents.normalizer import CLIP_STD, RunningNormalizer
from pendkit.agents.sequence_replay import SequenceBatch, SequenceReplay
from pendkit.agents.threads import use_kit_threads
from pendkit.device.blob_parts import DenseLayer, NetworkBlob

DEVICE_ACTIVATIONS = {"ReLU": "relu", "Tanh": "tanh", "Sigmoid": "sigmoid"}


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


def device_network(trunk: GruTrunk, modules, normalizer: RunningNormalizer, output: str) -> NetworkBlob:
    """The GRU of `trunk`, then [input, GRU state] through `modules` (Linear, activation, ...), as the network
    the device runs (`output`: "argmax" or "continuous")."""
    gru = trunk.gru
    weights = tuple(p.detach().numpy().astype(np.float32) for p in (gru.weight_ih_l0, gru.weight_hh_l0,
                                                                      gru.bias_ih_l0, gru.bias_hh_l0))
    layers = []
    for k, module in enumerate(modules):
        if hasattr(module, "weight"):
            follows = type(modules[k + 1]).__name__ if k + 1 < len(modules) else ""
            layers.append(DenseLayer(module.weight.detach().numpy().astype(np.float32),
                                     module.bias.detach().numpy().astype(np.float32),
                                     DEVICE_ACTIVATIONS.get(follows, "none")))
    return NetworkBlob(normalizer.mean.astype(np.float32), normalizer.std.astype(np.float32), CLIP_STD, layers,
                       weights, output)


class RecurrentAgent:
    """A trained-GRU agent's shared half: `NETWORK` names the attribute holding its online network (whose
    `trunk` is the GRU), `OPTIMIZERS` its optimisers; a subclass seeds torch, builds the network, then calls
    `_start`, and brings `act`, `update` and `device_network`. `step_extras()` hands the trainer the state
    before the last step, stored with it."""

    NETWORK = "net"
    OPTIMIZERS: tuple[str, ...] = ()

    def _start(self, input_dim: int, network: nn.Module, action_dim: int | None = None) -> None:
        self.input_dim, self.action_dim = input_dim, action_dim
        setattr(self, self.NETWORK, network)
        self.target = copy.deepcopy(network)
        self.normalizer = RunningNormalizer(input_dim)
        self.rng = np.random.default_rng(self.config.seed)
        self.steps = self.updates = 0
        self.reset()

    @property
    def trunk(self) -> GruTrunk:
        return getattr(self, self.NETWORK).trunk

    @property
    def hidden_dim(self) -> int:
        return self.config.gru_size

    def new_buffer(self, seed: int = 0) -> SequenceReplay:
        c = self.config
        return SequenceReplay(c.buffer_capacity, self.input_dim, c.gru_size, c.burn_in, c.sequence_length, seed,
                              action_dim=self.action_dim)

    def reset(self) -> None:
        self.hidden = torch.zeros(1, self.config.gru_size)
        self.hidden_before = self.hidden[0].numpy().copy()

    def step_extras(self) -> dict:
        return {"hidden": self.hidden_before}

    def track_input(self, x) -> None:
        """Fold a new raw input into the normalisation statistics (the trainer calls this once per step)."""
        self.normalizer.update(x)

    def _advance(self, x) -> torch.Tensor:
        """The GRU one step further on raw input `x` (call without gradient): the normalised input."""
        self.hidden_before = self.hidden[0].numpy().copy()
        z = self.normalizer.normalize(torch.as_tensor(np.asarray(x, dtype=np.float32)).reshape(1, -1))
        self.hidden = self.trunk.step(z, self.hidden)
        return z

    def _replayed(self, batch: SequenceBatch):
        """(inputs, next inputs, online GRU states, target GRU states) over a batch's trained steps: the
        stretches re-encoded from their stored states, the burn-in without gradient."""
        b = self.config.burn_in
        inputs, next_inputs = self.normalizer.normalize(batch.inputs), self.normalizer.normalize(batch.next_inputs)
        start_h = self.trunk.warm_start(inputs, batch.hidden, batch.starts, b)
        online_h = self.trunk.unroll(inputs[:, b:], torch.cat([start_h[:, None], batch.hidden[:, b + 1:]], 1),
                                     batch.starts[:, b:])
        with torch.no_grad():
            target_h = self.target.trunk.unroll(inputs, batch.hidden, batch.starts)[:, b:]
        return inputs[:, b:], next_inputs[:, b:], online_h, target_h

    def policy_state(self) -> dict:
        """What an actor needs to act: the network's weights and the input statistics (copied)."""
        return {self.NETWORK: {k: v.clone() for k, v in getattr(self, self.NETWORK).state_dict().items()},
                "normalizer": self.normalizer.state_dict()}

    def load_policy(self, state: dict) -> None:
        getattr(self, self.NETWORK).load_state_dict(state[self.NETWORK])
        self.normalizer.load_state_dict(state["normalizer"])

    def state_dict(self) -> dict:
        return {name: getattr(self, name).state_dict() for name in self._stateful()} | {
            "steps": self.steps, "updates": self.updates, "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict) -> None:
        for name in self._stateful():
            getattr(self, name).load_state_dict(state[name])
        self.steps, self.updates = state["steps"], state["updates"]
        self.rng.bit_generator.state = state["rng"]

    def _stateful(self) -> tuple[str, ...]:
        return (self.NETWORK, "target", *self.OPTIMIZERS, "normalizer")
