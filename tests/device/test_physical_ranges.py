"""Device blobs are held to physical ranges drawn from RigParams (issue 72 part 6): a crafted observer or swing-up
is refused by the parser in one line naming the term, its value and its range (the firmware's parser reads the
same table: tests/vectors/uploads.json); a controller that diverges all the same holds the servo, as the C++
core does, instead of raising on every tick; a virtual rig says a refusal once."""

import dataclasses
import logging
import time

import numpy as np
import pytest

import pendkit
from pendkit.deploy.on_twin import DeployError, onboard_episode, upload_to_twin
from pendkit.deploy.swingup_design import design_swing_up
from pendkit.device.controller_blob import BlobError, pack, parse
from pendkit.device.observer_blob import MODEL_FIELDS
from pendkit.device.physical_ranges import MODEL_RANGES, model_problem, nominal_model
from pendkit.rig import SERVO_PRESETS, RigParams
from tests.vectors.make_onboard_vectors import observed_blob


def test_the_ranges_are_the_kits_rig_through_the_models_own_formulas():
    from pendkit.control.model import FurutaModel

    assert list(MODEL_RANGES) == list(MODEL_FIELDS)
    for name in SERVO_PRESETS:
        params = RigParams.preset(name)
        assert nominal_model(params) == pytest.approx(dataclasses.asdict(FurutaModel.from_rig(params)), rel=1e-12)


def test_every_rig_the_kit_draws_is_inside_them():
    from pendkit.sim.randomize import observer_bank

    rigs = [RigParams.preset(name) for name in SERVO_PRESETS] + list(observer_bank())
    assert [model_problem(list(nominal_model(rig).values())) for rig in rigs] == [None] * len(rigs)
    parse(pack(observed_blob()))  # the kit's rig as an observer
    for controller in ("energy", "trajopt"):
        parse(pack(design_swing_up(None, controller)))


@pytest.mark.parametrize("changes, says", [
    ({"pendulum_inertia_kg_m2": 1e-38}, "observer 1 of 1: pendulum_inertia_kg_m2 = 1e-38 is outside its physical "
                                        "range 2.06e-05..0.206 kg m^2"),
    ({"servo_kp_n_m_per_rad": 1e9}, "servo_kp_n_m_per_rad = 1e+09 is outside its physical range 0.127..1.27e+03"),
    ({"servo_range_rad": 7.0}, "servo_range_rad = 7 is outside its physical range 0.0175..3.14 rad"),
    ({"coupling_kg_m2": 0.0075}, "does not exceed coupling_kg_m2^2 = 5.62e-05: no rigid body has that mass matrix"),
])
def test_an_observer_no_rig_has_is_refused_in_one_line(changes, says):
    with pytest.raises(BlobError) as refused:
        parse(pack(observed_blob(changes)))
    assert says in str(refused.value) and "\n" not in str(refused.value)


def test_a_swing_up_no_rig_has_is_refused_in_one_line():
    blob = design_swing_up(None, "energy")
    for name, value in (("servo_kp_per_inertia", 1e30), ("natural_frequency_rad_s", 1e-6)):
        with pytest.raises(BlobError, match=f"the swing-up's {name} = .* is outside its physical range"):
            parse(pack(dataclasses.replace(blob, scalars={**blob.scalars, name: value})))


def test_the_twins_device_refuses_a_1e_38_pendulum_by_name():
    env = pendkit.make(fidelity="realistic", action_mode="continuous")
    with pytest.raises(DeployError, match="pendulum_inertia_kg_m2 = 1e-38 is outside"):
        upload_to_twin(env, pack(observed_blob({"pendulum_inertia_kg_m2": 1e-38})))
    env.close()


@pytest.mark.parametrize("blob", [observed_blob(), design_swing_up(None, "energy")], ids=["policy", "swing-up"])
def test_a_controller_whose_arithmetic_fails_holds_the_servo_as_the_cpp_core(blob, monkeypatch):
    """Python raises (math.sin(inf): ValueError) where the C++ core's floats go NaN and the servo holds."""
    env = pendkit.make(fidelity="realistic", action_mode="continuous")
    upload_to_twin(env, pack(blob))
    runtime = env.unwrapped.backend.device.mcu.onboard.runtime

    def diverged(*args):
        raise ValueError("math domain error")

    monkeypatch.setattr(runtime, "tick", diverged)
    onboard_episode(env, seed=0, start="rest", steps=5)
    held = env.unwrapped.backend.device.mcu.servo_counts
    angles = onboard_episode(env, seed=0, start="rest", steps=30)
    assert np.all(np.isfinite(angles)) and env.unwrapped.backend.device.mcu.servo_counts == held
    env.close()


def test_a_virtual_rig_refuses_a_bad_upload_once_with_one_log_line(caplog):
    from pendkit.deploy.on_rig import RigSession, upload_to_rig
    from pendkit.link.driver import RigLink
    from pendkit.link.virtual_rig import LocalRig

    rig = LocalRig()
    link = RigLink(rig.rig, rig.url)
    try:
        link.connect()
        with caplog.at_level(logging.WARNING, logger="pendkit.virtual_rig"):
            with pytest.raises(DeployError, match="the rig refused the controller: observer 1 of 1: pendulum_inertia"):
                upload_to_rig(RigSession(link), pack(observed_blob({"pendulum_inertia_kg_m2": 1e-38})))
            time.sleep(0.5)  # ticks after the refusal
        onboard = rig.virtual.device.mcu.onboard
        assert onboard.blobs_refused == 1 and "pendulum_inertia_kg_m2 = 1e-38" in onboard.last_refusal
    finally:
        link.close()
        rig.stop()
    said = [r.getMessage() for r in caplog.records if r.name == "pendkit.virtual_rig"]
    assert len(said) == 1 and "refused an uploaded controller: observer 1 of 1: pendulum_inertia" in said[0], said


def test_a_rig_that_fails_every_tick_is_logged_once_not_every_tick(caplog):
    from pendkit.link.virtual_rig import VirtualRigGroup

    class Failing:
        rig = "r99"
        ticks = 0

        def connect(self, timeout_s): ...
        def start_clock(self, t0, speed): ...
        def publish_status(self): ...
        def close(self): ...
        def next_wake_s(self): return time.monotonic() + 0.001

        def advance(self, now_s):
            self.ticks += 1
            raise ValueError("math domain error")

    rig = Failing()
    with caplog.at_level(logging.ERROR, logger="pendkit.virtual_rig"), VirtualRigGroup([rig]):
        time.sleep(0.3)
    failures = [r for r in caplog.records if "failed a tick" in r.getMessage()]
    assert rig.ticks > 10 and len(failures) == 1
