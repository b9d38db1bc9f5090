"""The twin against analytic results and the servo's datasheet."""

import math

import mujoco
import numpy as np
import pytest

from pendkit.backend_contract import ServoCommand
from pendkit.rig import RigParams
from pendkit.sim.backend import SimBackend
from pendkit.sim.model import ARM_JOINT, PENDULUM_JOINT, build_model, fresh_model, small_oscillation_period_s


def zero_crossing_period_s(model, data, joint, seconds):
    address = model.joint(joint).qposadr[0]
    crossings = []
    while data.time < seconds:
        before, t0 = data.qpos[address], data.time
        mujoco.mj_step(model, data)
        after = data.qpos[address]
        if before > 0 >= after:
            crossings.append(t0 + (data.time - t0) * before / (before - after))
    return float(np.mean(np.diff(crossings)))


@pytest.mark.parametrize("preset", ["hitec-d645mw", "turnigy-tgy-wp23"])
def test_small_oscillation_period_matches_compound_pendulum(preset):
    params = RigParams.preset(preset).replace(pendulum_damping_n_m_s_per_rad=0.0)
    model = fresh_model(params, lock_arm=True)
    data = mujoco.MjData(model)
    data.qpos[0] = 0.02
    period = zero_crossing_period_s(model, data, PENDULUM_JOINT, 12.0)
    assert period == pytest.approx(small_oscillation_period_s(params), rel=0.02)
    assert 1.0 < period < 1.4  # a 40 cm dowel with a tip weight: about 1.18 s


def test_period_changes_with_the_tip_mass():
    heavier = RigParams().replace(tip_mass_kg=0.05)
    assert small_oscillation_period_s(heavier) > small_oscillation_period_s(RigParams())


def test_energy_is_conserved_without_damping():
    params = RigParams().replace(pendulum_damping_n_m_s_per_rad=0.0)
    model = fresh_model(params, energy=True)
    model.dof_damping[:] = 0.0
    model.actuator_gainprm[:] = 0.0
    model.actuator_biasprm[:] = 0.0
    model.jnt_limited[:] = 0  # the arm's end stops would absorb energy
    data = mujoco.MjData(model)
    data.qpos[model.joint(PENDULUM_JOINT).qposadr[0]] = 2.0
    data.qvel[model.joint(ARM_JOINT).dofadr[0]] = 1.0
    mujoco.mj_forward(model, data)
    start = data.energy.sum()
    scale = abs(data.energy[0]) + abs(data.energy[1])
    drifts = []
    for _ in range(2000):  # 10 s
        mujoco.mj_step(model, data)
        drifts.append(abs(data.energy.sum() - start))
    assert max(drifts) / scale < 1e-4


def test_damping_dissipates_energy():
    model = fresh_model(RigParams(), lock_arm=True, energy=True)
    data = mujoco.MjData(model)
    data.qpos[0] = 1.0
    mujoco.mj_forward(model, data)
    start = data.energy.sum()
    mujoco.mj_step(model, data, 2000)
    assert data.energy.sum() < start


def arm_speeds(backend, targets, steps_each=15):
    speeds = []
    for target in targets:
        for _ in range(steps_each):
            backend.step(ServoCommand("continuous", target_unit=target))
            speeds.append(abs(backend.true_state()["arm_velocity_rad_s"]))
    return np.array(speeds)


SWEEP = (1.0, -1.0, 0.3, -0.8, 1.0, -1.0)


@pytest.mark.parametrize("preset", ["hitec-d645mw", "hitec-d645mw-4v8", "turnigy-tgy-wp23", "mks-x5-hbl550"])
def test_servo_never_drives_faster_than_its_spec(preset):
    params = RigParams.preset(preset).replace(coupler_mass_kg=1e-6, dowel_mass_kg=1e-6, tip_mass_kg=1e-6,
                                              pendulum_damping_n_m_s_per_rad=0.0)
    backend = SimBackend(params, "ideal")  # no pendulum load: the servo on its own
    backend.reset(np.random.default_rng(0), "rest")
    speeds = arm_speeds(backend, SWEEP)
    assert speeds.max() <= params.servo_speed_rad_s * 1.001
    assert speeds.max() >= params.servo_speed_rad_s * 0.8  # and it does move briskly


def test_a_swinging_pendulum_drags_the_arm_only_slightly_past_its_spec():
    # The reaction of the pendulum (up to ~0.12 N m in this violent sweep) over the back-EMF damping
    # (0.21 N m s/rad) is the most it can add: about 0.6 rad/s.
    params = RigParams()
    backend = SimBackend(params, "ideal")
    backend.reset(np.random.default_rng(0), "rest")
    speeds = arm_speeds(backend, SWEEP)
    assert speeds.max() <= params.servo_speed_rad_s * 1.15


def test_servo_reaches_its_target_and_respects_the_range():
    params = RigParams()
    backend = SimBackend(params, "ideal")
    backend.reset(np.random.default_rng(0), "rest")
    for _ in range(30):
        backend.step(ServoCommand("continuous", target_unit=0.5))
    assert backend.true_state()["arm_angle_rad"] == pytest.approx(0.5 * params.servo_range_rad, abs=0.02)
    for _ in range(60):
        backend.step(ServoCommand("discrete", increment_counts=4))
    assert backend.true_state()["arm_angle_rad"] <= params.servo_range_rad + 0.01


def test_discrete_increment_rate():
    params = RigParams()
    backend = SimBackend(params, "ideal")
    backend.reset(np.random.default_rng(0), "rest")
    backend.step(ServoCommand("discrete", increment_counts=2))
    # 2 counts per 10 ms acting tick for 60 ms = 12 counts of 0.6 degrees
    assert backend.data.act[0] == pytest.approx(12 * params.servo_rad_per_count, rel=1e-6)


def test_torque_is_limited_to_stall():
    params = RigParams()
    model = build_model(params)
    assert model.actuator_forcerange[0, 1] == pytest.approx(params.servo_stall_torque_n_m)


def test_realistic_encoder_has_1024_levels_and_the_offset_is_calibrated_away():
    backend = SimBackend(RigParams(), "realistic")
    state = backend.reset(np.random.default_rng(0), "rest")
    assert state.encoder_counts in (0, 1023)  # hanging still: calibrated zero at the bottom
    seen = set()
    backend.data.qvel[backend._pend_v] = 9.0  # spin: every count should show up over time
    for _ in range(400):
        state = backend.step(ServoCommand("discrete", 0))
        seen.add(state.encoder_counts)
        levels = state.pendulum_angle_rad / (2 * math.pi / 1024)
        assert levels == pytest.approx(round(levels), abs=1e-9)
    assert seen <= set(range(1024)) and len(seen) > 100
