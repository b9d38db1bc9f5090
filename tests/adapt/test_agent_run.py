"""Adaptation's learned route: a policy reading the observer's estimate runs on the rig with an observer
designed for the rig that was identified, never for the rig's true parameters (which the laptop does not
have), and a policy on the raw readings gets no observer."""

import pendkit
from pendkit.adapt.rigs import twin_rig
from pendkit.adapt.routes import AgentRun
from pendkit.agents.runs import RunSpec
from pendkit.rig import RigParams

HIDDEN = RigParams.preset("hitec-d645mw-4v8").with_dowel_length(0.35)
IDENTIFIED = RigParams.preset("hitec-d645mw-4v8")  # what an identification found: close, not the truth


def test_the_observer_is_designed_for_the_identified_rig_on_the_hidden_one():
    run = AgentRun(RunSpec("td3+estimated", "realistic"), agent=None, inputs=None, observer_params=IDENTIFIED)
    env = twin_rig(HIDDEN, "none").make_env(**run.env_kwargs())
    assert env.unwrapped.params == HIDDEN  # the twin runs the hidden rig ...
    assert env.unwrapped._estimator.params == IDENTIFIED  # ... and the observer models what was identified
    env.close()


def test_a_policy_on_the_raw_readings_gets_no_observer():
    run = AgentRun(RunSpec("r-dqn", "realistic"), agent=None, inputs=None, observer_params=IDENTIFIED)
    assert "observer_params" not in run.env_kwargs()
    env = pendkit.make(fidelity="realistic", **run.env_kwargs())
    assert env.unwrapped.feature_source == "measured"
