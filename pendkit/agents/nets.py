"""The small networks and optimiser steps every agent shares."""

from __future__ import annotations

import math

import torch
from torch import nn

from pendkit.agents.threads import use_kit_threads


def mlp(input_dim: int, output_dim: int, hidden: tuple[int, ...]) -> nn.Sequential:
    """Linear layers with ReLU between them; the last layer is linear (torch then runs on the kit's threads)."""
    use_kit_threads()
    layers: list[nn.Module] = []
    width = input_dim
    for size in hidden:
        layers += [nn.Linear(width, size), nn.ReLU()]
        width = size
    layers.append(nn.Linear(width, output_dim))
    return nn.Sequential(*layers)


def adam(parameters, learning_rate: float) -> torch.optim.Adam:
    """Adam with the fused kernel where torch has it: with networks this small, per-tensor overhead dominates."""
    parameters = list(parameters)
    try:
        return torch.optim.Adam(parameters, lr=learning_rate, fused=True)
    except (RuntimeError, TypeError):
        return torch.optim.Adam(parameters, lr=learning_rate)


def descend(optimizer: torch.optim.Optimizer, loss: torch.Tensor, parameters,
            max_grad_norm: float | None = 10.0) -> None:
    """One optimiser step on `loss`, gradients clipped to `max_grad_norm` (None: not clipped)."""
    optimizer.zero_grad()
    loss.backward()
    if max_grad_norm is not None:
        nn.utils.clip_grad_norm_(parameters, max_grad_norm, foreach=True)
    optimizer.step()


def soft_update(network: nn.Module, target: nn.Module, tau: float) -> None:
    """target <- (1 - tau) target + tau network, parameter by parameter."""
    with torch.no_grad():
        for parameter, target_parameter in zip(network.parameters(), target.parameters()):
            target_parameter.mul_(1 - tau).add_(tau * parameter)


def masked_mean(values: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean over the entries where `mask` is 1 (replayed stretches are padded past an episode's end)."""
    return (values * mask).sum() / mask.sum().clamp(min=1.0)


def finite(value: float, what: str, remedy: str = "lower the learning rate") -> float:
    """`value` (a loss), or FloatingPointError naming `what` and `remedy` where it is NaN or infinite."""
    if not math.isfinite(value):
        raise FloatingPointError(f"{what} is not finite: {remedy}")
    return value
