"""`pendkit.deploy.on_twin.blob_on_rigs`: a blob run by each drawn rig's own twin device."""

from pendkit.deploy.on_twin import blob_on_rigs
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import pack
from pendkit.rig import RigParams
from pendkit.sim.randomize import RandomRig


def test_each_rigs_device_runs_the_uploaded_swing_up_from_rest_and_the_random_starts():
    default = RandomRig(RigParams(), None, 0)
    said = []
    outcomes = blob_on_rigs(pack(design_swing_up(RigParams())), {"a": default, "b": default}, starts=2,
                            say=lambda name, outcome: said.append(name))
    assert said == ["a", "b"]
    for outcome in outcomes.values():
        assert outcome.solved == [True, True, True], outcome  # nothing runs on the device unless it arrived
        assert None not in outcome.upright_s and all(f > 0.99 for f in outcome.held_fractions)  # up, and stays
    assert outcomes["a"].upright_s == outcomes["b"].upright_s  # the same seeds on the same rig
    assert len(set(outcomes["a"].upright_s)) == 3  # rest and two different random starts


def test_a_trained_policy_runs_as_its_blob_on_the_device_and_its_weights_decide_the_outcome():
    import copy

    from pendkit.agents.pretrained import policy_weights
    from pendkit.deploy.on_twin import policy_on_devices

    spec, state = policy_weights("r-td3-bank-robust")
    rig = {"default": RandomRig(RigParams(), None, 0)}
    shipped = policy_on_devices(spec, state, rig, starts=0)["default"]
    assert shipped.solved == [True], shipped  # the shipped policy, run by its device, holds from rest
    blank = copy.deepcopy(state)
    for tensor in blank["net"].values():
        tensor.zero_()
    assert policy_on_devices(spec, blank, rig, starts=0)["default"].solved == [False]  # the weights drive it
