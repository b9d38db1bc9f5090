"""Lab 00: the student's reward and upright fraction drive what the tour prints, and the text's figures are
the run's (the observation's age, the reflection's returns)."""

import math
import re
from pathlib import Path

import nbformat
import numpy as np

import pendkit
import pendkit.features
from pendkit.grading import load_lab, run_task
from tests.labs.student_loop import printed_by_lab

ROOT = Path(__file__).resolve().parents[2]

REWARD_IN_RAD_S = '''
def reward(angle_from_upright_rad, velocity_rad_s):
    return float(-angle_from_upright_rad**2 - 0.5 * velocity_rad_s**2)
'''
UPRIGHT_WITH_LE = '''
def upright_fraction(angles_from_upright_rad):
    return float(np.mean(np.abs(np.asarray(angles_from_upright_rad, dtype=float)) <= 0.3))
'''
YOUR_RETURN = 'print("\\n".join(your_return(reward, trace)))'
BOUNDARY = "upright_fraction([0.3, -0.3, 0.29"


def text_of(notebook_name: str) -> str:
    notebook = nbformat.read(ROOT / "solutions" / notebook_name, as_version=4)
    return " ".join(" ".join(cell.source for cell in notebook.cells).split())


def returns(printed: str) -> tuple[float, float]:
    yours, kit = re.search(r"return (-?[\d.]+) \(the plot's title, from the env's own reward: (-?[\d.]+)\)",
                           printed).groups()
    return float(yours), float(kit)


def test_lab00_the_students_reward_sums_to_the_plots_return_and_a_rad_s_one_parts_from_it_named():
    right = printed_by_lab("00_tour.ipynb", BOUNDARY, then=YOUR_RETURN)
    wrong = printed_by_lab("00_tour.ipynb", BOUNDARY, {"reward": REWARD_IN_RAD_S, "upright_fraction": UPRIGHT_WITH_LE},
                           then=YOUR_RETURN)
    yours, kit = returns(right)
    assert yours == kit and ": the same" in right, right
    yours, same_kit = returns(wrong)
    assert same_kit == kit and yours < 5 * kit, wrong  # several times lower: rad/s squared is 39 times rev/s squared
    assert "the velocity arrives in rad/s; convert it to rev/s" in wrong, wrong
    # the boundary line under the demo: 0.5 as solved, 1.0 when 0.3 itself counts as upright
    assert "upright_fraction([0.3, -0.3, 0.29, -0.29]) = 0.5" in right
    assert "upright_fraction([0.3, -0.3, 0.29, -0.29]) = 1.0" in wrong


def test_lab00_a_non_strict_bound_loses_a_public_point_naming_the_bound():
    load_lab("00")
    results = run_task("00.upright_fraction", lambda angles: float(np.mean(np.abs(np.asarray(angles)) <= 0.3)))
    failed = [r for r in results if not r.passed]
    assert [r.name for r in failed] == ["the_bound_is_strict"] and not failed[0].hidden
    assert "the bound is strict (< 0.3, not <= 0.3)" in failed[0].message


def test_lab00_an_observation_on_the_realistic_twin_is_27_ms_old_as_the_text_says():
    env = pendkit.make(fidelity="realistic", start="rest")
    observation, info = env.reset(seed=0)
    env.close()
    age = dict(zip([f.name for f in env.unwrapped.features], observation))["observation_age"]
    assert f"{age:.3f}" == "0.027" and round(1000 * info["state"].observation_age_s) == 27
    assert "a few tens of milliseconds old" in text_of("00_tour.ipynb") and "says 0.027 s, 27 ms" in text_of(
        "00_tour.ipynb")


def test_lab00_the_reflections_returns_hanging_still_and_a_good_swing_up():
    from pendkit.control.swingup import SwingUpController
    from pendkit.episode import run_episode

    text = text_of("00_tour.ipynb")
    env = pendkit.make(fidelity="realistic", start="rest")
    _, info = env.reset(seed=0)
    steps = env.spec.max_episode_steps
    hanging = pendkit.features.reward(info["state"])
    env.close()
    assert steps == 500 and math.isclose(hanging, -math.pi**2)
    assert f"{hanging:.2f}" == "-9.87" and round(steps * hanging) == -4935
    assert "$-\\pi^2 \\approx -9.87$ per step, about $-4935$ per episode" in text
    # "a good swing-up scores above about -300": the kit's swing-up from rest, a whole episode on the realistic twin
    swing_env = pendkit.make(action_mode="continuous", fidelity="realistic", start="rest")
    trace = run_episode(swing_env, SwingUpController.for_env(swing_env), seed=0, steps=steps)
    swing_env.close()
    assert -300 < trace.episode_return < -100, trace.episode_return
    assert "a good swing-up scores above about $-300$" in text


def test_lab00_the_rig_in_numbers_is_the_kits_rig():
    from pendkit.rig import RigParams

    params, text = RigParams(), text_of("00_tour.ipynb")
    env = pendkit.make(start="rest")
    steps, dt_s = env.spec.max_episode_steps, env.unwrapped.dt
    env.close()
    assert (params.servo_name, params.servo_speed_s_per_60deg, params.servo_stall_torque_kg_cm) == (
        "Hitec D645MW", 0.20, 11.3)
    assert "Hitec D645MW, 0.20 s per 60° at 6 V, 11.3 kg·cm" in text
    assert (params.arm_length_m, params.servo_range_deg, params.dowel_length_m, params.tip_mass_kg) == (
        0.4, 90.0, 0.4, 0.0095)
    assert "400 mm aluminium arm in the horizontal plane, within ±90°" in text and "9.5 g tip weight" in text
    assert params.encoder_counts == 1024 and "1024 positions per turn" in text
    assert (params.streaming_period_ms, params.acting_period_ms, params.control_step_ms) == (25.0, 10.0, 60.0)
    assert "reads the encoder every 25 ms, moves the servo every 10 ms" in text and "acts every 60 ms" in text
    assert steps == 500 and round(steps * dt_s, 6) == 30.0 and "an episode is 500 steps (30 s)" in text
    assert round((2 * math.pi) ** 2) == 39 and "$(2\\pi)^2 \\approx 39$ times smaller" in text
