"""Lab 07: the student's target drives the curve, and the notebook names a myopic one."""

import re

import pytest

from tests.labs.student_loop import printed_by_lab

pytestmark = pytest.mark.expensive  # minutes of notebook runs: scheduled first (conftest.py)

MYOPIC_TARGET = '''
def td_target(rewards, dones, next_q_online, next_q_target, gamma, double):
    return np.asarray(rewards, dtype=float)  # no future
'''


def test_lab07_a_target_without_the_future_is_named_under_its_curve_and_greedy_runs_say_if_they_held():
    right = printed_by_lab("07_dqn.ipynb", "def myopic_target(")
    wrong = printed_by_lab("07_dqn.ipynb", "def myopic_target(", {"td_target": MYOPIC_TARGET})
    assert "is the myopic one" not in right, right
    assert "your curve is the myopic one, episode for episode" in wrong, wrong
    judged = printed_by_lab("07_dqn.ipynb", "run = judge_policy(")
    assert re.search(r"your verdict: held \d+ of 10: (not )?solved \(the kit says (not )?solved\)", judged), judged
    assert re.search(r"the first episode alone \(hanging still\) (held|did not hold)", judged), judged
