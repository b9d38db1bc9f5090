"""One reader of trained policies (`policy_artifact`) for eval, export, deploy, adapt and the queue: a shipped
policy or a run folder, the rig it was trained for and the delays its twin told it."""

from __future__ import annotations

import pytest

from pendkit.agents.policy_artifact import policy_artifact
from pendkit.agents.runs import RunSpec, build_run, save_weights
from pendkit.errors import ConfigError
from pendkit.network import median_latency_ms
from pendkit.rig import RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS
from pendkit.timing import host_timing


def test_a_run_trained_on_a_preset_names_that_rig_and_its_twins_delays(tmp_path):
    spec = RunSpec("td3+estimated", "realistic", preset="turnigy-tgy-wp23")
    env, agent, _ = build_run(spec)
    save_weights(tmp_path / "final.pt", agent, spec)
    artifact = policy_artifact(tmp_path)
    assert artifact.trained_rig == RigParams.preset("turnigy-tgy-wp23") == env.unwrapped.params
    assert artifact.timing == env.unwrapped.timing  # what the twin told the learner, without building one
    latency_ms = median_latency_ms(FIDELITY_PRESETS["realistic"].network.latency)
    assert artifact.timing.command_delay_s == host_timing(artifact.trained_rig, env.unwrapped.dt, latency_ms,
                                                          0.0).command_delay_s
    assert artifact.source.endswith("final.pt")
    env.close()


def test_a_shipped_policy_by_name_and_the_refusals():
    artifact = policy_artifact(name="dqn-ideal")
    assert artifact.source == "policy dqn-ideal" and artifact.trained_rig == RigParams()
    assert artifact.timing.command_delay_s == 0.0  # the ideal twin has no delays
    with pytest.raises(ConfigError, match="dqn-ideal"):
        policy_artifact(name="dqn-ideal2")
    with pytest.raises(ConfigError, match="one of them"):
        policy_artifact()
