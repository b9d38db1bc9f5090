import math

import pytest

from pendkit.backend_contract import RigState
from pendkit.features import PAPER_FEATURES, angle_from_upright_rad, resolve_features, reward


def state(angle_from_bottom, velocity=0.0):
    return RigState(0.0, angle_from_bottom, velocity, 0.0, 0.0, 0.0, 0.0)


def test_reward_is_the_papers():
    assert reward(state(math.pi)) == 0.0
    assert reward(state(0.0)) == pytest.approx(-math.pi**2)
    # one revolution per second at the top costs 0.5
    assert reward(state(math.pi, 2 * math.pi)) == pytest.approx(-0.5)
    assert reward(state(math.pi + 0.3)) == pytest.approx(-0.09)


def test_angle_from_upright_wraps():
    assert angle_from_upright_rad(state(math.pi)) == 0.0
    assert angle_from_upright_rad(state(3 * math.pi + 0.1)) == pytest.approx(0.1)
    assert angle_from_upright_rad(state(0.0)) == pytest.approx(-math.pi)


def test_paper_features_are_seven():
    assert len(resolve_features("paper")) == 7 == len(PAPER_FEATURES)
