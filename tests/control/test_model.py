"""The analytic model from RigParams against the MuJoCo twin (two independent derivations)."""

import math

import mujoco
import numpy as np
import pytest

from pendkit.control.model import FurutaModel, discretise, filtered_model
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.sim.model import build_model


def mujoco_accelerations(params, x, target):
    model = build_model(params)
    data = mujoco.MjData(model)
    data.qpos[:] = x[:2]
    data.qvel[:] = x[2:]
    data.act[0] = target
    mujoco.mj_forward(model, data)
    return data.qacc.copy()


@pytest.mark.parametrize("preset", ["hitec-d645mw", "turnigy-tgy-wp23"])
def test_nonlinear_accelerations_match_mujoco(preset):
    params = RigParams.preset(preset)
    model = FurutaModel.from_rig(params)
    rng = np.random.default_rng(0)
    for _ in range(20):
        x = np.array([rng.uniform(-1, 1), rng.uniform(0, 2 * math.pi), rng.uniform(-3, 3), rng.uniform(-8, 8)])
        target = rng.uniform(-1.4, 1.4)
        np.testing.assert_allclose(model.accelerations(x, target), mujoco_accelerations(params, x, target),
                                   rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("about, alpha", [("upright", math.pi), ("hanging", 0.0)])
def test_linearisation_matches_finite_differences_of_the_twin(about, alpha):
    params = RigParams()
    system = FurutaModel.from_rig(params).linearise(about)
    base = np.array([0.0, alpha, 0.0, 0.0])
    eps = 1e-6
    columns = []
    for i in range(4):
        step = np.zeros(4)
        step[i] = eps
        columns.append((mujoco_accelerations(params, base + step, 0.0)
                        - mujoco_accelerations(params, base - step, 0.0)) / (2 * eps))
    b_fd = (mujoco_accelerations(params, base, eps) - mujoco_accelerations(params, base, -eps)) / (2 * eps)
    a_fd = np.column_stack(columns)
    np.testing.assert_allclose(np.asarray(system.A)[2:], a_fd, rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(np.asarray(system.B)[2:, 0], b_fd, rtol=1e-4, atol=1e-4)


def test_upright_is_unstable_and_hanging_is_stable():
    model = FurutaModel.from_rig()
    upright = np.linalg.eigvals(np.asarray(model.linearise("upright").A))
    hanging = np.linalg.eigvals(np.asarray(model.linearise("hanging").A))
    assert max(upright.real) > 3.0  # about sqrt(m g l / J_effective)
    assert max(hanging.real) < 0
    assert model.natural_frequency_rad_s == pytest.approx(RigParams().pendulum_natural_frequency_rad_s)


def test_action_filter_and_delay_in_the_discrete_model():
    system = FurutaModel.from_rig().linearise("upright")
    plain = filtered_model(system, 0.06, 0.0)
    zoh = discretise(system, 0.06)
    np.testing.assert_allclose(np.asarray(plain.A)[:4, :4], np.asarray(zoh.A), rtol=1e-9)
    np.testing.assert_allclose(np.asarray(plain.B)[:4], np.asarray(zoh.B), rtol=1e-9, atol=1e-12)
    filtered = filtered_model(system, 0.06, 0.85)
    assert np.asarray(filtered.A)[4, 4] == 0.85 and np.asarray(filtered.B)[4, 0] == pytest.approx(0.15)
    delayed = filtered_model(system, 0.06, 0.85, input_delay_s=0.03)
    # with a delay, part of the step is still driven by the previous target
    assert np.linalg.norm(np.asarray(delayed.B)[:4]) < np.linalg.norm(np.asarray(filtered.B)[:4])


@pytest.mark.parametrize("kwargs, words", [
    ({"filter_coefficient": 1.0}, "filter_coefficient"),
    ({"filter_coefficient": 0.5, "input_delay_s": 0.06}, "input_delay_s"),
])
def test_bad_model_settings(kwargs, words):
    system = FurutaModel.from_rig().linearise("upright")
    with pytest.raises(ConfigError, match=words):
        filtered_model(system, 0.06, **kwargs)
    with pytest.raises(ConfigError, match="about"):
        FurutaModel.from_rig().linearise("sideways")
