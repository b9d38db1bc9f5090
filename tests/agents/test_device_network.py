"""The learners the device runs: the registry names them, and each one's agent provides its network."""

from __future__ import annotations

import numpy as np
import pytest

import pendkit
from pendkit.agents.learners import DEVICE_LEARNERS, LEARNERS, build_learner
from pendkit.device.blob_parts import NetworkBlob


def test_the_registry_names_the_device_learners_and_their_layouts():
    assert DEVICE_LEARNERS == {"r-dqn": 1, "r-td3+both": 2}
    assert all(LEARNERS[name].device_layout == layout for name, layout in DEVICE_LEARNERS.items())


@pytest.mark.parametrize("name", sorted(DEVICE_LEARNERS))
def test_a_device_learners_agent_gives_the_network_it_acts_with(name):
    env = pendkit.make(**LEARNERS[name].env_kwargs())
    agent, inputs = build_learner(name, env)
    env.close()
    network = agent.device_network()
    assert isinstance(network, NetworkBlob) and network.input_dim == inputs.dim
    assert network.gru[1].shape == (3 * agent.config.gru_size, agent.config.gru_size)
    assert network.output == ("continuous" if LEARNERS[name].continuous else "argmax")
    assert network.layers[-1].activation == ("tanh" if LEARNERS[name].continuous else "none")
    assert network.layers[-1].weight.shape[0] == (1 if LEARNERS[name].continuous else 5)
    assert all(layer.weight.dtype == np.float32 for layer in network.layers)
