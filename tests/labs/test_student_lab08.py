"""Lab 08: the student's delayed_view is what the plot shows and what the agents learn behind, with its delay."""

import pytest

from tests.labs.student_loop import printed_by_lab

pytestmark = pytest.mark.expensive  # notebook runs: scheduled first (conftest.py)

ONE_STEP_SHORT = '''
def delayed_view(observations, delay_steps):
    observations = np.asarray(observations)
    return observations[np.maximum(0, np.arange(len(observations)) - delay_steps + 1)]
'''


def test_lab08_a_delay_one_step_short_is_said_under_the_plot_and_a_right_one_is_not():
    right = printed_by_lab("08_gru_rdqn.ipynb", "seen = attempt(delayed_view")
    wrong = printed_by_lab("08_gru_rdqn.ipynb", "seen = attempt(delayed_view", {"delayed_view": ONE_STEP_SHORT})
    assert "late" not in right, right
    assert "shows them 1 step late (60 ms)" in wrong, wrong
