"""Lab 04: the student's gain and model drive the balance the twin shows."""

import re

from tests.labs.student_loop import printed_by_lab

WRONG_LQR_GAIN = '''
def lqr_gain(A, B, q_diagonal, r):
    gain, _, _ = control.dlqr(A, B, np.diag(q_diagonal), [[r]])
    return -np.asarray(gain)  # the sign of u = -Kx lost
'''


def worst_error_deg(text: str) -> float:
    return float(re.search(r"worst error in the last 2 s ([\d.]+) deg", text).group(1))


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
