"""Lab 04: the student's gain and model drive the balance the twin shows."""

import re

import pytest

from tests.labs.student_loop import printed_by_lab

WRONG_LQR_GAIN = '''
def lqr_gain(A, B, q_diagonal, r):
    gain, _, _ = control.dlqr(A, B, np.diag(q_diagonal), [[r]])
    return -np.asarray(gain)  # the sign of u = -Kx lost
'''


def worst_error_deg(text: str) -> float:
    return float(re.search(r"worst error in the last 2.4 s ([\d.]+) deg", text).group(1))


def test_lab04_the_students_k_balances_the_twin_and_a_wrong_k_drops_it():
    right = worst_error_deg(printed_by_lab("04_lqr.ipynb", "StateFeedback(K"))
    wrong = worst_error_deg(printed_by_lab("04_lqr.ipynb", "StateFeedback(K", {"lqr_gain": WRONG_LQR_GAIN}))
    assert right < 1.0 and wrong > 45.0, (right, wrong)



HANGING_A = '''
def upright_matrices(model):
    mass = np.array([[model.arm_inertia_kg_m2, -model.coupling_kg_m2],
                     [-model.coupling_kg_m2, model.pendulum_inertia_kg_m2]])
    forces = np.array([
        [-model.servo_kp_n_m_per_rad, 0.0, -(model.servo_kv_n_m_s_per_rad + model.arm_damping_n_m_s_per_rad), 0.0],
        [0.0, -model.gravity_torque_n_m, 0.0, -model.pendulum_damping_n_m_s_per_rad],  # -mgl: the hanging model
    ])
    inverse = np.linalg.inv(mass)
    a = np.zeros((4, 4))
    a[0, 2] = a[1, 3] = 1.0
    a[2:, :] = inverse @ forces
    b = np.zeros((4, 1))
    b[2:, 0] = inverse @ np.array([model.servo_kp_n_m_per_rad, 0.0])
    return a, b
'''


def test_lab04_k_is_designed_on_the_students_a_and_b_and_the_hanging_model_falls():
    right = worst_error_deg(printed_by_lab("04_lqr.ipynb", "StateFeedback(K"))
    wrong = worst_error_deg(printed_by_lab("04_lqr.ipynb", "StateFeedback(K", {"upright_matrices": HANGING_A}))
    assert right < 1.0 and wrong > 30.0, (right, wrong)


def solution_cell(start: str) -> str:
    import nbformat

    from tests.labs.student_loop import ROOT

    notebook = nbformat.read(ROOT / "solutions" / "04_lqr.ipynb", as_version=4)
    return next(c.source for c in notebook.cells if c.cell_type == "code" and start in c.source)


@pytest.mark.expensive  # the notebook up to question 1's cell, twice
def test_lab04_question_1s_cell_tries_other_weights_and_leaves_the_labs_k_alone():
    trial = solution_cell("TRY_Q_DIAG, TRY_R_WEIGHT =")
    heavier = trial.replace("TRY_Q_DIAG, TRY_R_WEIGHT = [2.0, 40.0, 0.05, 0.5], 3.0",
                            "TRY_Q_DIAG, TRY_R_WEIGHT = [2.0, 400.0, 0.05, 0.5], 3.0")
    assert heavier != trial
    printed = printed_by_lab("04_lqr.ipynb", "TRY_Q_DIAG, TRY_R_WEIGHT =", then=heavier)
    assert re.search(r"the lab's weights : K = .*largest pole magnitude 0\.870", printed), printed
    assert re.search(r"your trial +: K = .*largest pole magnitude 0\.931", printed), printed  # the note's 0.93
    assert printed.count("the lab's weights") == 2  # before and after the trial: the lab's K is the same


@pytest.mark.expensive  # the notebook up to the delay cell
def test_lab04_the_delay_cell_prints_the_parts_a_student_adds_up_and_one_window():
    printed = printed_by_lab("04_lqr.ipynb", "def final_error_deg(")
    assert "a command reaches the servo 23 ms after it is sent" in printed, printed
    assert "a reading reaches the laptop 8 ms after it is taken (the WiFi), then waits 12.5 ms" in printed
    assert "43.5 ms in all" in printed and "worst error in the last 2.4 s of 7.2 s:" in printed  # ci: 120 steps
    errors = [float(x) for x in re.findall(r"step: +([\d.]+) deg", printed)]
    assert len(errors) == 3 and errors[0] > 170 and errors[1] < 2 and errors[2] >= errors[1], errors


NO_COUPLING = HANGING_A.replace("-model.coupling_kg_m2", "0.0").replace("-model.gravity", "model.gravity")


def test_lab04_matrices_without_the_coupling_name_dlqr_as_the_cause_in_the_plot_and_the_trial_cell():
    """Both functions written, no gain from dlqr: the title and the trial cell say so, never "write lqr_gain"."""
    assert "coupling_kg_m2" not in NO_COUPLING and "-model.gravity" not in NO_COUPLING
    printed = printed_by_lab("04_lqr.ipynb", "TRY_Q_DIAG, TRY_R_WEIGHT =", {"upright_matrices": NO_COUPLING},
                             then="print(axis.get_title())")
    assert "no trial: no K: control.dlqr found no gain for your A and B" in printed, printed
    assert printed.strip().endswith("(is the coupling through M in them?)") and "write" not in printed, printed


def test_lab04_the_trial_cell_refuses_a_zero_r_and_says_why():
    weights = "TRY_Q_DIAG, TRY_R_WEIGHT = [2.0, 40.0, 0.05, 0.5], "
    trial = solution_cell(weights).replace(weights + "3.0", weights + "0.0")
    printed = printed_by_lab("04_lqr.ipynb", weights, then=trial)
    assert "R must be above 0 and Q's entries 0 or above (R = 0.0" in printed, printed
    assert printed.count("your trial") == 1, printed  # the lab's own weights' run only
