"""The invert check for labs whose student code drives the twin: run the solution notebook up to the cell
the student watches, once as solved and once with one function answered wrongly, and read what the cell
printed. A wrong answer must change what the student sees."""

import os
import re
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from pendkit.grading.runner import DEMO_TAG

ROOT = Path(__file__).resolve().parents[2]

WRONG_LQR_GAIN = '''
def lqr_gain(A, B, q_diagonal, r):
    gain, _, _ = control.dlqr(A, B, np.diag(q_diagonal), [[r]])
    return -np.asarray(gain)  # the sign of u = -Kx lost
'''
WRONG_DIRECTION = '''
def pumping_direction(angle_from_bottom_rad, velocity_rad_s):
    return 1 if velocity_rad_s * math.cos(angle_from_bottom_rad) > 0 else -1  # brakes
'''


def printed_by_lab(notebook_name: str, stop_at: str, replace: dict[str, str] | None = None,
                   then: str | None = None) -> str:
    """Run the solution's code cells up to the one containing `stop_at`, with the cells defining the named
    functions replaced, and then the code `then` if given; return what that cell (and `then`) printed. The demo cells
    before it are left out, as the grader leaves them out: nothing later needs them."""
    notebook = nbformat.read(ROOT / "solutions" / notebook_name, as_version=4)
    kept = []
    for cell in notebook.cells:
        if cell.cell_type != "code" or (DEMO_TAG in cell.metadata.get("tags", []) and stop_at not in cell.source):
            continue
        for name, source in (replace or {}).items():
            if f"def {name}(" in cell.source:
                cell.source = source
        kept.append(cell)
        if stop_at in cell.source:
            break
    if then is not None:
        kept.append(nbformat.v4.new_code_cell(then))
    notebook.cells = kept
    os.environ["PENDKIT_MODE"] = "ci"
    NotebookClient(notebook, timeout=300, kernel_name="python3",
                   resources={"metadata": {"path": str(ROOT / "solutions")}}).execute()
    printing = kept[-2:] if then is not None else kept[-1:]
    return "".join(o.get("text", "") for cell in printing for o in cell.outputs if o.get("output_type") == "stream")


@pytest.fixture(autouse=True)
def _restore_mode():
    saved = os.environ.get("PENDKIT_MODE")
    yield
    if saved is None:
        os.environ.pop("PENDKIT_MODE", None)
    else:
        os.environ["PENDKIT_MODE"] = saved


def worst_error_deg(text: str) -> float:
    return float(re.search(r"worst error in the last 2 s ([\d.]+) deg", text).group(1))


def test_lab04_the_students_k_balances_the_twin_and_a_wrong_k_drops_it():
    right = worst_error_deg(printed_by_lab("04_lqr.ipynb", "StateFeedback(K"))
    wrong = worst_error_deg(printed_by_lab("04_lqr.ipynb", "StateFeedback(K", {"lqr_gain": WRONG_LQR_GAIN}))
    assert right < 1.0 and wrong > 45.0, (right, wrong)


def test_lab05_the_students_functions_swing_the_twin_up_and_a_braking_rule_does_not():
    right = printed_by_lab("05_swingup.ipynb", "parts=yours), seed=0")
    wrong = printed_by_lab("05_swingup.ipynb", "parts=yours), seed=0", {"pumping_direction": WRONG_DIRECTION})
    assert re.search(r"time to upright: [\d.]+ s", right), right
    assert "not upright at the end of the" in wrong and "None" not in wrong, wrong


NEVER_STOPS = '''
def should_stop(arm_angle_rad, pendulum_velocity_rad_s, observation_age_s):
    return None
'''


def test_lab09_the_students_watchdog_holds_the_rig_when_the_wifi_drops_and_a_silent_one_does_not():
    right = printed_by_lab("09_deploy.ipynb", "WifiDropsOut(SwingUpController")
    wrong = printed_by_lab("09_deploy.ipynb", "WifiDropsOut(SwingUpController", {"should_stop": NEVER_STOPS})
    assert "your watchdog held the rig" in right and "old" in right, right
    assert "your watchdog did not stop the rig" in wrong, wrong


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
    assert "found no solution" in wrong, wrong
    fallback = "energy pumping (no plan: the tracker's fallback)"
    assert "tracked plan" not in wrong.split("fell back")[-1], wrong  # the fallback is not called a plan
    assert upright_at_s(wrong, fallback) > upright_at_s(right, "tracked plan") + 1.0, (right, wrong)


SIGNED_COST = '''
def matching_cost(simulated_rad, recorded_rad):
    return float(np.mean(np.asarray(simulated_rad) - np.asarray(recorded_rad)))  # gaps cancel
'''
# Run after the student's identification, in the same kernel: the signed cost searches the same recordings
# (two runs of the real-time rig record it apart, and a busy machine can make one run's recordings poor).
IDENTIFY_AGAIN_WITH_THE_SIGNED_COST = SIGNED_COST + '''
signed = identify(recordings, pendkit.RigParams(), max_evaluations=evaluations, cost=your_cost)
print(f"signed cost: gap of {kit_cost(signed.params, signed.latency_ms, recordings):.4f} rad^2")
'''


def gaps_to_nominal(text: str) -> tuple[float, float]:
    """The twins identified with the student's cost and then the signed one: each one's mean squared gap to
    the rig as a fraction of the nominal twin's, on the same recordings."""
    found, nominal = re.search(r"gap of ([\d.]+) rad\^2 \(the nominal twin: ([\d.]+)\)", text).groups()
    signed = re.search(r"signed cost: gap of ([\d.]+) rad\^2", text).group(1)
    return float(found) / float(nominal), float(signed) / float(nominal)


@pytest.mark.expensive
def test_lab09_the_students_cost_identifies_a_twin_that_follows_the_rig_and_a_signed_one_does_not():
    text = printed_by_lab("09_deploy.ipynb", "your_cost(params, latency_ms", then=IDENTIFY_AGAIN_WITH_THE_SIGNED_COST)
    right, signed = gaps_to_nominal(text)
    assert right < 0.75 and signed > right + 0.2, text  # the nominal twin is 1.0


PUSH_WITH_THE_WRONG_SIGN = '''
def pendulum_acceleration(angle_rad, rate_rad_s, arm_acceleration_rad_s2, natural_frequency_rad_s,
                          damping_per_s, coupling):
    return (-natural_frequency_rad_s**2 * math.sin(angle_rad) - damping_per_s * rate_rad_s
            + coupling * math.cos(angle_rad) * arm_acceleration_rad_s2)  # the arm's push reversed
'''
BIG_ENDIAN_CHUNKS = '''
def upload_chunks(blob, start=0, chunk_bytes=1024):
    return [b"PKUP" + struct.pack(">II", offset, len(blob)) + blob[offset:offset + chunk_bytes]
            for offset in range(start, len(blob), chunk_bytes)]
'''


def estimate_error(text: str, whose: str = "your model") -> float:
    return float(re.search(whose + r" ([\d.]+) rad/s", text).group(1))


def test_lab10_the_students_model_drives_the_devices_estimate_and_a_reversed_push_shows():
    right = printed_by_lab("10_on_device.ipynb", "onboard.runtime.pendulum_acceleration")
    wrong = printed_by_lab("10_on_device.ipynb", "onboard.runtime.pendulum_acceleration",
                           {"pendulum_acceleration": PUSH_WITH_THE_WRONG_SIGN})
    assert "solved=2/2" in right, right
    assert estimate_error(wrong) > 1.3 * estimate_error(right), (right, wrong)
    # the kit's own model is printed beside the student's, and a wrong one is told so
    assert estimate_error(right, "the kit's model") == pytest.approx(estimate_error(right), abs=0.02), right
    assert "clearly worse than the kit's" in wrong and "clearly worse" not in right, (right, wrong)


def test_lab10_the_students_chunks_reach_the_rig_and_big_endian_ones_do_not():
    right = printed_by_lab("10_on_device.ipynb", "chunker=your_chunks")
    wrong = printed_by_lab("10_on_device.ipynb", "chunker=your_chunks", {"upload_chunks": BIG_ENDIAN_CHUNKS})
    # 2 chunks, or more when the busy room's WiFi lost one and the upload resumed
    assert re.search(r"the rig took the controller: 1260 bytes in [2-9] chunks", right) and "1 accepted" in right, right
    assert "the upload failed" in wrong and "0 accepted" in wrong, wrong
    assert "big-endian; the rig reads little-endian" in wrong, wrong  # the cause, not the blob's size


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
