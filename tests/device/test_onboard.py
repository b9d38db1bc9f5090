"""Controllers the device runs itself: the swing-up blob, the Python runtime against the shared vectors,
uploads in chunks, the twin's device swinging up on poor WiFi, the safety stops above it, and
`pendkit deploy` to a virtual rig over a real broker."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import pendkit
from pendkit.cli import main
from pendkit.deploy.export import read_vectors
from pendkit.deploy.on_twin import DeployError, onboard_episode, upload_to_twin
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import BlobError, pack, parse
from pendkit.device.onboard import OnboardController, blob_chunks
from pendkit.device.scheduler import DeviceScheduler
from pendkit.device.swingup_runtime import MODES, SwingUpRuntime
from pendkit.features import holds_upright
from pendkit.network import IMPAIRMENTS
from pendkit.rig import RigParams
from pendkit.sim.fidelity import FIDELITY_PRESETS
from tests.vectors.make_onboard_vectors import upload_scenarios

VECTORS = Path(__file__).resolve().parents[1] / "vectors"


def twin(network: str = "poor-wifi", params: RigParams | None = None):
    fidelity = dataclasses.replace(FIDELITY_PRESETS["realistic"], network=IMPAIRMENTS[network])
    return pendkit.make(fidelity=fidelity, params=params, action_mode="continuous")


@pytest.mark.parametrize("controller", ["energy", "trajopt"])
def test_swing_up_blob_round_trips_and_refuses_damage(controller):
    blob = design_swing_up(RigParams(), controller)
    data = pack(blob)
    back = parse(data)
    assert back.kind == "swing-up" and back.plan_steps == blob.plan_steps
    assert back.scalars == pytest.approx(blob.scalars, rel=1e-6)
    assert (blob.plan_steps > 0) == (controller == "trajopt")
    damaged = bytearray(data)
    damaged[20] ^= 0x40
    with pytest.raises(BlobError, match="CRC"):
        parse(bytes(damaged))


@pytest.mark.parametrize("controller", ["energy", "trajopt"])
def test_python_runtime_reproduces_the_shared_vectors(controller):
    runtime = SwingUpRuntime(parse((VECTORS / f"swing-up-{controller}.pkcb").read_bytes()))
    starts, inputs, outputs = read_vectors(VECTORS / f"swing-up-{controller}.pktv")
    same_mode, worst, ticks = 0, 0.0, 0
    for start, (pendulum, target), (want, mode) in zip(starts, inputs, outputs):
        if start:
            runtime.reset(float(pendulum), float(target))
            continue
        got = runtime.tick(float(pendulum), float(target))
        ticks += 1
        if MODES.index(runtime.mode) == int(mode):
            same_mode += 1
            worst = max(worst, abs(got - float(want)))
    assert same_mode >= 0.999 * ticks and worst < 1e-4
    assert {int(m) for m in outputs[~starts, 1]} >= {MODES.index("swing"), MODES.index("balance")}


def test_upload_vectors_are_not_stale():
    committed = json.loads((VECTORS / "uploads.json").read_text())["scenarios"]
    assert json.loads(json.dumps(upload_scenarios())) == committed, "run python -m tests.vectors.make_onboard_vectors"


def test_a_lost_chunk_is_resumed_and_a_bad_blob_changes_nothing():
    good = pack(design_swing_up(RigParams(), "trajopt"))
    chunks = blob_chunks(good, chunk_bytes=256)
    device = OnboardController()
    device.chunk(chunks[0])
    device.chunk(chunks[2])  # chunk 1 was lost
    assert device.status()["ignored_chunks"] == 1 and device.status()["received"] == 256
    for chunk in blob_chunks(good, start=device.status()["received"], chunk_bytes=256):
        device.chunk(chunk)
    assert device.status()["accepted"] == 1 and device.status()["kind"] == "swing-up"
    active = device.runtime
    damaged = bytearray(good)
    damaged[-10] ^= 1
    for chunk in blob_chunks(bytes(damaged)):
        device.chunk(chunk)
    status = device.status()
    assert status["refused"] == 1 and "CRC" in status["last_refusal"]
    assert device.runtime is active and status["bytes"] == len(good)


def test_the_authors_firmware_takes_no_uploads():
    scheduler = DeviceScheduler(RigParams(), protocol=1)
    for chunk in blob_chunks(pack(design_swing_up(RigParams(), "energy"))):
        scheduler.receive(chunk, 0)
    assert scheduler.rejected_commands == 1 and scheduler.logic.onboard.runtime is None


@pytest.mark.parametrize("controller", ["energy", "trajopt"])
def test_the_device_swings_up_and_holds_on_poor_wifi(controller):
    env = twin("poor-wifi")
    upload_to_twin(env, pack(design_swing_up(env.unwrapped.params, controller)))
    angles = onboard_episode(env, seed=3, start="rest", steps=300)
    env.close()
    assert holds_upright(angles, 150), f"last angles {np.round(angles[-5:], 2)}"


@pytest.mark.parametrize("controller", ["energy", "trajopt"])
def test_the_device_balances_a_fast_lightly_damped_servo(controller):
    """The HSB-9380TH (0.17 s/60 deg, damping ratio 0.2) rings at about 12 Hz: an arm estimate that has the
    servo take each target at once, rather than at its next PWM frame, ran ahead of it and the balance fell
    in every episode."""
    params = RigParams.preset("hitec-hsb-9380th")
    env = twin("classroom-wifi", params)
    upload_to_twin(env, pack(design_swing_up(params, controller)))
    episodes = [onboard_episode(env, seed=seed, start="rest", steps=500) for seed in range(3)]
    env.close()
    tails = [float(np.max(np.abs(angles[-200:]))) for angles in episodes]
    assert all(holds_upright(angles, 200) for angles in episodes), f"largest angle in the last 200 steps: {tails}"


def test_the_watchdog_stops_the_device_controller_and_a_host_action_takes_over():
    env = twin("none")
    upload_to_twin(env, pack(design_swing_up(env.unwrapped.params, "energy")))
    backend = env.unwrapped.backend
    onboard_episode(env, seed=1, start="rest", steps=10)
    mcu = backend.device.mcu
    assert mcu.onboard.running
    backend.device.run(40, lambda *_: None)  # 200 ms without a heartbeat: past the 150 ms watchdog
    assert "watchdog" in mcu.flags
    held = mcu.servo_counts
    backend.device.run(60, lambda *_: None)
    assert mcu.servo_counts == held and mcu.onboard.running  # held, not stopped: a heartbeat resumes it
    backend.step_with_message("d")
    backend.step_with_message("d")
    assert not mcu.onboard.running
    env.close()


def test_upload_to_an_env_without_a_device_is_refused():
    env = pendkit.make(fidelity="ideal", action_mode="continuous")
    with pytest.raises(DeployError, match="realistic"):
        upload_to_twin(env, pack(design_swing_up(RigParams(), "energy")))
    env.close()


def test_deploy_to_a_virtual_rig_over_mqtt(tmp_path):
    from pendkit.link.virtual_rig import LocalRig

    rig = LocalRig(impairment="classroom-wifi")
    try:
        result = CliRunner().invoke(main, ["deploy", "--controller", "trajopt", "--rig", rig.rig, "--broker", rig.url,
                                           "--seconds", "4"])
        onboard = rig.virtual.device.mcu.onboard
        assert result.exit_code == 0, result.output
        blob_bytes = len(pack(design_swing_up(RigParams(), "trajopt")))
        assert f"uploaded {blob_bytes} bytes" in result.output and "deg from upright" in result.output
        assert onboard.blobs_accepted == 1 and not onboard.running  # stopped at the end (k0)
    finally:
        rig.stop()


def test_deploy_names_firmware_without_on_device_control():
    from pendkit.link.virtual_rig import LocalRig

    rig = LocalRig(protocol=1)
    try:
        result = CliRunner().invoke(main, ["deploy", "--controller", "energy", "--rig", rig.rig, "--broker", rig.url,
                                           "--seconds", "1"])
        assert result.exit_code != 0 and "without on-device controllers (protocol 1)" in result.output, result.output
    finally:
        rig.stop()


def test_python_device_policy_reproduces_the_shared_vectors():
    from pendkit.device.logic import McuObservation
    from pendkit.device.policy_runtime import DevicePolicy

    blob = parse((VECTORS / "r-dqn-realistic-policy.pkcb").read_bytes())
    assert blob.kind == "policy" and blob.network.input_dim == 12
    policy = DevicePolicy(blob, RigParams())
    rows = json.loads((VECTORS / "policy-device.json").read_text())["decisions"]
    same = decisions = 0
    for row in rows:
        if "start" in row:
            policy.reset()
            continue
        millis, position, servo, omega, accel, arm = row["reading"]
        reading = McuObservation(millis, position, servo, omega, accel, arm, frozenset())
        assert np.allclose(policy.inputs(reading, row["now_ms"]), row["inputs"], atol=1e-6)
        action = None
        while action is None:
            action = policy.tick(reading, row["now_ms"])
        decisions += 1
        same += action == row["action"]
    assert decisions > 900 and same == decisions


def test_a_policy_on_the_device_holds_where_the_laptop_loses_it_on_poor_wifi():
    from pendkit.agents.pretrained import policy_weights
    from pendkit.agents.runs import build_run, evaluate_agent, held_fraction
    from pendkit.deploy.export import policy_blob

    spec, state = policy_weights("r-dqn-realistic")
    fidelity = dataclasses.replace(FIDELITY_PRESETS["realistic"], network=IMPAIRMENTS["poor-wifi"])
    env = pendkit.make(fidelity=fidelity, action_mode="discrete")
    _, agent, inputs = build_run(spec, env)
    agent.load_policy(state)
    laptop = evaluate_agent(env, agent, inputs, 2, 10_000, "random").held_fractions
    upload_to_twin(env, pack(policy_blob(agent, env.unwrapped.params)))
    device = [held_fraction(onboard_episode(env, seed=10_000 + k, start="random")) for k in range(2)]
    env.close()
    assert min(f or 0.0 for f in device) > max(f or 0.0 for f in laptop) + 0.3, (laptop, device)
