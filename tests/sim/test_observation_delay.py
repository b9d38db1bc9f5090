import numpy as np
import pytest

import pendkit
from pendkit.errors import ConfigError
from pendkit.sim.observation_delay import ObservationDelay


def rollout(env, steps=12):
    observation, _ = env.reset(seed=5, options={"start": "rest"})
    seen, angles = [observation], []
    for step in range(steps):
        observation, _, _, _, info = env.step(step % 5)
        seen.append(observation)
        angles.append(info["angle_from_upright_rad"])
    return np.array(seen), angles


def test_the_agent_sees_the_observation_from_k_steps_ago_and_the_physics_is_unchanged():
    true_seen, true_angles = rollout(pendkit.make(fidelity="ideal"))
    late_seen, late_angles = rollout(ObservationDelay(pendkit.make(fidelity="ideal"), 2))
    assert late_angles == true_angles
    np.testing.assert_array_equal(late_seen[2:], true_seen[:-2])
    np.testing.assert_array_equal(late_seen[:3], np.repeat(true_seen[:1], 3, axis=0))
    assert not np.array_equal(late_seen, true_seen)


def test_zero_delay_is_the_env_itself():
    np.testing.assert_array_equal(rollout(ObservationDelay(pendkit.make(), 0))[0], rollout(pendkit.make())[0])


@pytest.mark.parametrize("bad", [-1, 1.5, 101])
def test_bad_delays_are_refused(bad):
    with pytest.raises(ConfigError, match="delay_steps"):
        ObservationDelay(pendkit.make(), bad)
