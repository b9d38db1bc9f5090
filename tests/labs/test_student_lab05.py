"""Lab 05: the student's pumping law and catch set drive the swing-up the twin shows."""

import re

import pytest

from tests.labs.student_loop import printed_by_lab

pytestmark = pytest.mark.expensive  # minutes of notebook runs: scheduled first (conftest.py)

WRONG_DIRECTION = '''
def pumping_direction(angle_from_bottom_rad, velocity_rad_s):
    return 1 if velocity_rad_s * math.cos(angle_from_bottom_rad) > 0 else -1  # brakes
'''



def test_lab05_the_students_functions_swing_the_twin_up_and_a_braking_rule_does_not():
    right = printed_by_lab("05_swingup.ipynb", "parts=yours), seed=0")
    wrong = printed_by_lab("05_swingup.ipynb", "parts=yours), seed=0", {"pumping_direction": WRONG_DIRECTION})
    assert re.search(r"time to upright: [\d.]+ s", right), right
    assert "not upright at the end of the" in wrong and "None" not in wrong, wrong



CATCH_AROUND_HANGING = '''
def catch_set(upright_rad, angle_rad, velocity_rad_s, arm_angle_rad, arm_velocity_rad_s):
    lower = [-arm_angle_rad, -angle_rad, -arm_velocity_rad_s, -velocity_rad_s]  # centred on hanging
    upper = [arm_angle_rad, angle_rad, arm_velocity_rad_s, velocity_rad_s]
    return lower, upper
'''


def upright_at_s(text: str, label: str) -> float:
    return float(re.search(rf"{re.escape(label)}: upright at ([\d.]+) s", text).group(1))


def test_lab05_the_students_problem_plans_a_swing_up_faster_than_pumping_and_a_wrong_catch_set_does_not():
    # Times to upright printed by the lab are the ideal twin's simulated seconds (seed 0), not wall time.
    right = printed_by_lab("05_swingup.ipynb", "your_planner(step_model, made)")
    wrong = printed_by_lab("05_swingup.ipynb", "your_planner(step_model, made)", {"catch_set": CATCH_AROUND_HANGING})
    assert upright_at_s(right, "tracked plan") < 0.6 * upright_at_s(right, "your pumping law"), right
    # the text's default-rig figures (the lab runs on the default rig under ci and the grader)
    assert (upright_at_s(right, "tracked plan"), upright_at_s(right, "your pumping law")) == (1.56, 4.02), right
    assert "found no solution" in wrong, wrong
    fallback = "energy pumping (no plan: the tracker's fallback)"
    assert "tracked plan" not in wrong.split("fell back")[-1], wrong  # the fallback is not called a plan
    assert upright_at_s(wrong, fallback) > upright_at_s(right, "tracked plan") + 1.0, (right, wrong)


COST_FROM_ZERO = '''
def terminal_cost(state, upright_rad):
    arm, pendulum, arm_rate, pendulum_rate = state[:4]
    return 0.1 * arm**2 + 10 * pendulum**2 + 0.1 * arm_rate**2 + pendulum_rate**2  # from 0, not upright
'''


def test_lab05_on_the_default_rig_the_approach_keeps_the_search_and_a_cost_from_zero_is_named():
    right = printed_by_lab("05_swingup.ipynb", "your_planner(step_model, made)")
    wrong = printed_by_lab("05_swingup.ipynb", "your_planner(step_model, made)", {"terminal_cost": COST_FROM_ZERO})
    assert "it kept the search's motion" in right and "must cost 0" not in right, right  # the text's claim
    assert "must cost 0" in wrong and "from upright_rad" in wrong, wrong


OVERSPIN_IN_REV_S = '''
def path_limits(arm_limit_rad, overspin_rev_s):
    return arm_limit_rad, overspin_rev_s  # left in rev/s
'''


def test_lab05_a_problem_without_a_solution_prints_the_limits_it_had():
    wrong = printed_by_lab("05_swingup.ipynb", "your_planner(step_model, made)", {"path_limits": OVERSPIN_IN_REV_S})
    assert "found no solution" in wrong and "the pendulum's rate within +-2.00 rad/s" in wrong, wrong
    assert "passes the bottom near 2 w0 = 10.6 rad/s" in wrong and "pendulum [-3.39, -2.89]" in wrong, wrong


DIRECTION_BY_SIGN = '''
def pumping_direction(angle_from_bottom_rad, velocity_rad_s):
    return -int(np.sign(velocity_rad_s * math.cos(angle_from_bottom_rad)))  # 0 at rest
'''


def test_lab05_a_direction_of_0_is_named_by_the_swing_up_and_the_sweep_with_no_name_error():
    printed = printed_by_lab("05_swingup.ipynb", "sweep_steps = budget(", {"pumping_direction": DIRECTION_BY_SIGN})
    assert printed.startswith("no sweep: it runs your swing-up too, and the swing-up stopped on your functions' "
                              "answer: the pumping direction must be +1 or -1, got 0"), printed
    assert "return +1" in printed and "write" not in printed, printed


def test_lab05_a_direction_of_0_leaves_the_plan_cell_running_beside_the_kits_pumping_law():
    printed = printed_by_lab("05_swingup.ipynb", "your_planner(step_model, made)",
                             {"pumping_direction": DIRECTION_BY_SIGN})
    assert "tracked plan: upright at" in printed, printed
    assert "the kit's pumping law (yours did not run: the swing-up cell says why): upright at" in printed, printed
