"""A continuous policy the device runs with its own bank of observers (policy layout 2): the device's observers
follow the host's, the blob is checked whole, and the shipped bank policy run by the twin's device holds."""

import dataclasses
import math

import numpy as np
import pytest

import pendkit
from pendkit.backend_contract import ServoCommand
from pendkit.device.blob_parts import BlobError
from pendkit.device.controller_blob import pack, parse
from pendkit.device.observer_runtime import DeviceObserverBank
from pendkit.features import holds_upright
from pendkit.rig import RigParams


def _candidates():
    from pendkit.sim.randomize import observer_bank

    return observer_bank()[:3]


def test_the_devices_observer_bank_follows_the_hosts_step_for_step():
    from pendkit.control.observer_bank import ObserverBank
    from pendkit.deploy.export import observer_section

    env = pendkit.make(fidelity="realistic", action_mode="continuous", params=_candidates()[1])
    base = env.unwrapped
    host = ObserverBank(_candidates(), base.dt, base.timing)
    device = DeviceObserverBank(observer_section(_candidates(), base.params, 0.85, 1, base.timing), base.dt)
    env.reset(seed=4, options={"start": "random"})
    shown_host, shown_device = host.reset(base._state), device.reset(base._state)
    worst, chosen = 0.0, set()
    for k in range(250):
        env.step(np.array([math.sin(k / 7.0)], np.float32))  # swings that tell the candidates apart
        unit = base._filtered_unit
        shown_host = host.update(ServoCommand("continuous", target_unit=unit), base._state)
        shown_device = device.update(unit, base._state)
        assert host.chosen == device.chosen
        chosen.add(device.chosen)
        worst = max(worst, abs(shown_host.arm_angle_rad - shown_device.arm_angle_rad),
                    abs(shown_host.pendulum_angle_rad - shown_device.pendulum_angle_rad),
                    abs(shown_host.pendulum_velocity_rad_s - shown_device.pendulum_velocity_rad_s) / 10)
    env.close()
    assert worst < 1e-5  # the gains travel as float32
    assert chosen != {0}  # the readings moved the choice off the first candidate at least once


def _blob():
    from pendkit.agents.pretrained import policy_weights
    from pendkit.deploy.learned_blob import learned_policy_blob

    return learned_policy_blob(*policy_weights("r-td3-bank-robust"))


def test_a_layout_2_blob_survives_its_bytes_and_a_damaged_one_is_refused():
    pytest.importorskip("torch")
    blob = _blob()
    again = parse(pack(blob))
    assert again.layout == 2 and again.observers.candidates == 13 and again.network.output == "continuous"
    assert np.array_equal(again.observers.gains, blob.observers.gains)
    assert pack(again) == pack(blob)
    bad_model = dataclasses.replace(blob, observers=dataclasses.replace(
        blob.observers, models=blob.observers.models * np.array([-1.0] + [1.0] * 10, np.float32)))
    with pytest.raises(BlobError, match="positive inertias"):
        parse(pack(bad_model))
    with pytest.raises(BlobError, match="NaN"):
        nan_gains = dataclasses.replace(blob.observers, gains=blob.observers.gains * np.nan)
        pack(dataclasses.replace(blob, observers=nan_gains))
    with pytest.raises(BlobError, match="acting ticks"):  # a million ticks a step (found by the C++ fuzzer)
        parse(pack(dataclasses.replace(blob, acting_period_s=1e-7)))
    seen_twice = dataclasses.replace(blob, observers=dataclasses.replace(blob.observers, actions_seen=2))
    with pytest.raises(BlobError, match="inputs"):
        parse(pack(seen_twice))  # the network reads one last action, not two


def test_the_shipped_bank_policy_run_by_the_twins_device_holds_and_a_reversed_one_does_not():
    pytest.importorskip("torch")
    from pendkit.deploy.on_twin import onboard_episode, upload_to_twin

    blob = _blob()
    env = pendkit.make(fidelity="realistic", action_mode="continuous", params=RigParams())
    results = {}
    reversed_output = dataclasses.replace(blob, network=dataclasses.replace(blob.network, layers=[
        *blob.network.layers[:-1], dataclasses.replace(blob.network.layers[-1], weight=-blob.network.layers[-1].weight,
                                                       bias=-blob.network.layers[-1].bias)]))
    for name, chosen in (("shipped", blob), ("reversed", reversed_output)):
        upload_to_twin(env, pack(chosen))
        assert env.unwrapped.backend.device.mcu.onboard.runtime.bank.observers[0].steps == 12
        results[name] = [holds_upright(onboard_episode(env, seed=30 + k, start=start, steps=500), 200)
                         for k, start in enumerate(("rest", "random", "random"))]
    env.close()
    assert results == {"shipped": [True] * 3, "reversed": [False] * 3}, results


def test_python_observed_policy_reproduces_the_shared_vectors():
    """tests/vectors/observed-policy-device.json, which the firmware's C++ core replays too."""
    import json
    from pathlib import Path

    from pendkit.device.observation import McuObservation
    from pendkit.device.observed_policy import ObservedDevicePolicy

    vectors = Path(__file__).resolve().parents[1] / "vectors"
    blob = parse((vectors / "r-td3-bank-robust-policy.pkcb").read_bytes())
    policy = ObservedDevicePolicy(blob, RigParams())
    decisions = worst_input = worst_target = 0.0
    observers = set()
    for row in json.loads((vectors / "observed-policy-device.json").read_text())["decisions"]:
        if "start" in row:
            policy.reset()
            continue
        reading = McuObservation(*row["reading"], frozenset())
        target = None
        while target is None:
            target = policy.tick(reading, row["now_ms"])
        want = np.array(row["inputs"])
        relative = np.abs(policy.network_inputs - want) / np.maximum(1, np.abs(want))
        worst_input = max(worst_input, float(np.max(relative)))
        worst_target = max(worst_target, abs(target - row["target_unit"]))
        policy.follow(row["action"], row["target_unit"])  # what the other side will replay
        observers.add(policy.bank.chosen)
        decisions += 1
    assert decisions > 500 and worst_input <= 1e-5 and worst_target <= 1e-5, (worst_input, worst_target)
    assert len(observers) > 1  # the bank's choice moved during the recorded episodes


def test_a_bank_is_designed_for_the_devices_delays_and_a_single_observer_keeps_its_trainings():
    pytest.importorskip("torch")
    from pendkit.agents.pretrained import policy_weights
    from pendkit.deploy.learned_blob import learned_policy_blob

    bank = learned_policy_blob(*policy_weights("r-td3-bank-robust")).observers
    single = learned_policy_blob(*policy_weights("r-td3-robust")).observers
    trained = pendkit.make(fidelity="realistic").unwrapped.timing
    assert bank.candidates == 13 and bank.reading_latency_s == 0.0
    assert bank.actuation_delay_s == pytest.approx(RigParams().pwm_period_ms / 2000)  # half a PWM frame
    assert single.candidates == 1
    assert (single.actuation_delay_s, single.reading_latency_s) == pytest.approx(
        (trained.command_delay_s, trained.reading_delay_s))
    assert single.actuation_delay_s > bank.actuation_delay_s  # the laptop's network and acting tick on top


def test_observers_designed_for_other_delays_when_asked_carry_them_to_the_device():
    pytest.importorskip("torch")
    from pendkit.agents.pretrained import policy_weights
    from pendkit.backend_contract import BackendTiming
    from pendkit.deploy.learned_blob import learned_policy_blob

    shipped = learned_policy_blob(*policy_weights("r-td3-bank-robust"))
    asked = learned_policy_blob(*policy_weights("r-td3-bank-robust"),
                                timing=BackendTiming(0.06, 0.02, 0.005, firmware_readings=True))
    assert (asked.observers.actuation_delay_s, asked.observers.reading_latency_s) == pytest.approx((0.02, 0.005))
    carried = parse(pack(asked)).observers  # the device predicts over the delays its blob carries
    assert (carried.actuation_delay_s, carried.reading_latency_s) == pytest.approx((0.02, 0.005))
    assert pack(asked) != pack(shipped)
