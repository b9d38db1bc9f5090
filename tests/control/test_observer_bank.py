"""A bank of observers on a rig nobody identified: it settles on the candidate whose model predicts the
readings, shows a better estimate than the nominal rig's observer alone, and with one candidate is that
observer exactly."""

import dataclasses

import numpy as np
import pytest

import pendkit
from pendkit.errors import ConfigError
from pendkit.rig import RigParams

HIDDEN = dataclasses.replace(RigParams.preset("hitec-d645mw-4v8"),
                             servo_full_torque_error_deg=4.0).with_dowel_length(0.32)
OTHER = RigParams.preset("mks-x5-hbl550").with_dowel_length(0.44)


def choices(candidates, steps=250):
    """The bank's choice each step on the hidden rig's twin, driven by swinging targets."""
    env = pendkit.make(fidelity="realistic", params=HIDDEN, action_mode="continuous", features="estimated",
                       observer_params=candidates)
    env.reset(seed=4)
    chosen = []
    for k in range(steps):
        env.step(np.array([0.8 * np.sin(k / 6)], dtype=np.float32))
        chosen.append(env.unwrapped._estimator.chosen)
    env.close()
    return np.bincount(chosen[100:], minlength=len(candidates)) / (steps - 100)


def test_the_bank_settles_on_the_candidate_that_is_the_rig():
    share = choices((RigParams(), OTHER, HIDDEN))
    assert share[2] > 0.5 and share[2] == share.max()  # the hidden rig's own model, most of the time
    assert choices((HIDDEN, RigParams(), OTHER))[0] > 0.5  # wherever it stands in the bank


def test_with_the_bank_the_robust_policy_swings_up_a_rig_where_the_nominal_observer_fails_it():
    """td3-robust was trained with observers told each rig; on the HSB-9380TH the nominal rig's observer
    misleads it, the bank (which does not hold that rig) does not (docs/results/robust.md)."""
    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.rig_suite import observer_bank, rig_env
    from pendkit.agents.runs import build_run, evaluate_agent
    from pendkit.sim.randomize import RandomRig

    spec, state = policy_weights("td3-robust")
    rig = RandomRig(RigParams.preset("hitec-hsb-9380th"))
    held = {}
    for name, candidates in (("nominal", RigParams()), ("bank", observer_bank())):
        env = rig_env(rig, spec, observer_params=candidates)
        _, agent, inputs = build_run(spec, env)
        agent.load_state_dict(state)
        held[name] = evaluate_agent(env, agent, inputs, 1, seed=10_000, start="rest").solved[0]
    assert held == {"nominal": False, "bank": True}


def test_a_bank_of_one_is_that_observer():
    env_bank = pendkit.make(fidelity="realistic", action_mode="continuous", features="estimated",
                            observer_params=[OTHER])
    env_one = pendkit.make(fidelity="realistic", action_mode="continuous", features="estimated", observer_params=OTHER)
    shown = [[env.reset(seed=2)[0]] for env in (env_bank, env_one)]
    for k in range(40):
        for env, trace in zip((env_bank, env_one), shown):
            trace.append(env.step(np.array([np.cos(k / 4)], dtype=np.float32))[0])
    assert np.allclose(shown[0], shown[1])
    assert env_bank.unwrapped._estimator.params == OTHER


@pytest.mark.parametrize("bad", [[], (RigParams(), "mks-x5-hbl550"), "mks-x5-hbl550"])
def test_a_bank_takes_rigs_only(bad):
    with pytest.raises(ConfigError, match="observer_params"):
        pendkit.make(fidelity="realistic", features="estimated", observer_params=bad)


def test_a_policy_trained_with_observers_told_each_rig_meets_an_unknown_rig_with_the_bank():
    from pendkit.agents.rig_suite import observer_bank, rig_env
    from pendkit.agents.runs import RunSpec
    from pendkit.sim.randomize import RandomRig

    told = RunSpec("td3+estimated", "realistic", observer="rig")
    env = rig_env(RandomRig(HIDDEN), told)
    assert env.unwrapped._estimator.candidates == observer_bank() and HIDDEN not in observer_bank()
    assert rig_env(RandomRig(HIDDEN), told, observer_knows_rig=True).unwrapped._estimator.params == HIDDEN
    assert rig_env(RandomRig(HIDDEN), RunSpec("td3+estimated", "realistic")).unwrapped._estimator.params == RigParams()


def test_a_learner_trained_with_the_bank_keeps_it_through_every_drawn_rig_and_meets_rigs_with_it():
    from pendkit.agents.rig_suite import rig_env
    from pendkit.agents.runs import RunSpec, make_env
    from pendkit.sim.randomize import RandomRig, observer_bank

    spec = RunSpec("r-td3+both", "realistic", randomize="robust", observer="bank")
    env = make_env(spec)
    for seed in range(2):
        env.reset(seed=seed)
        assert env.unwrapped._estimator.candidates == observer_bank()
        assert env.unwrapped.params != RigParams()  # a drawn rig, the bank unchanged
    assert rig_env(RandomRig(HIDDEN), spec).unwrapped._estimator.candidates == observer_bank()
    with pytest.raises(ConfigError, match="observer must be one of"):
        RunSpec("td3+estimated", "realistic", observer="oracle")
