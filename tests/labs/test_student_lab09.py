"""Lab 09: the student's watchdog and matching cost drive the rig runs and the identified twin."""

import re
from pathlib import Path

import nbformat
import pytest

from tests.labs.student_loop import printed_by_lab
from tests.labs.test_lab_claims import deployed_policies

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.expensive  # minutes of notebook runs: scheduled first (conftest.py)

NEVER_STOPS = '''
def should_stop(arm_angle_rad, pendulum_velocity_rad_s, observation_age_s):
    return None
'''


def test_lab09_the_students_watchdog_holds_the_rig_when_the_wifi_drops_and_a_silent_one_does_not():
    right = printed_by_lab("09_deploy.ipynb", "WifiDropsOut(SwingUpController")
    wrong = printed_by_lab("09_deploy.ipynb", "WifiDropsOut(SwingUpController", {"should_stop": NEVER_STOPS})
    assert "your watchdog held the rig" in right and "old" in right, right
    assert "your watchdog did not stop the rig" in wrong, wrong


SIGNED_COST = '''
def matching_cost(simulated_rad, recorded_rad):
    return float(np.mean(np.asarray(simulated_rad) - np.asarray(recorded_rad)))  # gaps cancel
'''
# Run after the student's identification, in the same kernel: the signed cost searches the same recordings
# (two runs of the real-time rig record it apart, and a busy machine can make one run's recordings poor).
IDENTIFY_AGAIN_WITH_THE_SIGNED_COST = SIGNED_COST + '''
signed = identify(recordings, pendkit.RigParams(), max_evaluations=evaluations, cost=your_cost)
print(f"signed cost: gap of {kit_cost(signed.params, signed.latency_ms, recordings):.4f} rad^2")
print(f"the signed cost on the nominal twin: {your_cost(pendkit.RigParams(), 10.0, recordings):.4f} rad^2")
no_wrap = [float(np.mean((simulate(pendkit.RigParams(), 10.0, r) - np.asarray(r.pendulum_rad)) ** 2))
           for r in recordings]
print(f"a cost without the wrap on the nominal twin: {np.mean(no_wrap):.4f} rad^2")
'''


def gaps_to_nominal(text: str) -> tuple[float, float]:
    """The twins identified with the student's cost and then the signed one: each one's mean squared gap to
    the rig as a fraction of the nominal twin's, on the same recordings."""
    found, nominal = re.search(r"gap of ([\d.]+) rad\^2 \(the nominal twin: ([\d.]+)\)", text).groups()
    signed = re.search(r"signed cost: gap of ([\d.]+) rad\^2", text).group(1)
    return float(found) / float(nominal), float(signed) / float(nominal)


def test_lab09_the_students_cost_identifies_a_twin_that_follows_the_rig_and_a_signed_one_is_told_apart():
    text = printed_by_lab("09_deploy.ipynb", "your_cost(params, latency_ms", then=IDENTIFY_AGAIN_WITH_THE_SIGNED_COST)
    right, signed = gaps_to_nominal(text)
    # the nominal twin is 1.0: the right cost's twin follows the rig more closely. Which wrong cost's twin follows
    # it less, one search's fraction does not tell (lab 09's text: the fractions overlap; a signed cost's twin
    # came out closer than the right one's once, on a loaded machine): the cost beside the kit's does, below
    assert right < 0.75, text
    # what tells a cost right or wrong in every run: the student's cost beside the kit's on the nominal twin
    yours, kits = re.search(r"your matching_cost on the nominal twin: ([\d.]+) rad\^2 \(the kit's: ([\d.]+)\)",
                            text).groups()
    assert abs(float(yours) - float(kits)) <= 0.05 * float(kits), text  # "within a few percent"
    no_wrap = float(re.search(r"a cost without the wrap on the nominal twin: ([\d.]+) rad\^2", text).group(1))
    assert no_wrap > 500 * float(kits), text  # "hundreds to thousands of times" (615-1640 recorded)
    signed_on_nominal = float(re.search(r"the signed cost on the nominal twin: (-?[\d.]+) rad\^2", text).group(1))
    assert abs(signed_on_nominal - float(kits)) > 0.5 * float(kits), text  # the gaps cancel: far from the kit's


def test_lab09_the_deployed_policies_come_up_on_their_twins_and_seldom_on_a_twin_of_the_rig():
    """What the policy cell's text says to expect, in the lab's setting (400 steps): up within a few seconds on the
    twin each was trained on, seed 0; on a simulated twin of the lab's virtual rig (its servo, the classroom
    Wi-Fi), from 10 starts hanging still, as often as the text says (`dqn-ideal` from none, `td3-realistic` from
    2 of 10). The real-time rig itself is not asserted: `td3-realistic` came up there in 4 of 20 runs, which the
    text quotes from docs/results/labs.md."""
    import dataclasses

    import pendkit
    from pendkit.agents.pretrained import load_policy, policy_env_options
    from pendkit.deploy import run_guarded
    from pendkit.features import time_to_upright_s
    from pendkit.network import IMPAIRMENTS
    from pendkit.sim.fidelity import FIDELITY_PRESETS

    def upright_at(env, name, seed=0):
        run = run_guarded(env, load_policy(name, env), lambda *reading: None, steps=400, seed=seed)
        up = time_to_upright_s(list(run.trace.pendulum_from_upright_rad), 0.06)
        return None if up is None or up > 400 * 0.06 - 2.0 else up  # the lab's measure: held the last 2 s at least

    like_the_rig = dataclasses.replace(FIDELITY_PRESETS["realistic"], network=IMPAIRMENTS["classroom-wifi"])
    params = pendkit.RigParams.preset("hitec-d645mw-4v8")
    text = " ".join(" ".join(cell.source for cell in nbformat.read(ROOT / "solutions" / "09_deploy.ipynb",
                                                                      as_version=4).cells).split())
    said = {"dqn-ideal": "`dqn-ideal` came up from none", "td3-realistic": "`td3-realistic` from {k} of 10"}
    for name in deployed_policies():
        options = policy_env_options(name)
        on_twin = upright_at(pendkit.make(**options, start="rest"), name)
        assert on_twin is not None and on_twin < 5.0, (name, on_twin)
        rest = {k: v for k, v in options.items() if k != "fidelity"}
        ups = [upright_at(pendkit.make(**rest, fidelity=like_the_rig, params=params, start="rest"), name, seed)
               for seed in range(10)]
        came = sum(up is not None for up in ups)
        assert said[name].format(k=came) in text and (came == 0) == (name == "dqn-ideal"), (name, ups)


def test_lab09_on_a_twin_of_its_rig_a_design_for_its_servo_comes_up_and_one_for_the_ideal_twin_does_not():
    """What the closing-the-gap text quotes: the kit's swing-up designed for the ideal twin, for this rig's own
    servo, and for the servo as the lab re-identifies it (from the same step video as the notebook), each from
    rest on a simulated twin of the lab's virtual rig (its servo preset, the classroom Wi-Fi; no laptop in the
    loop), 6 starts of the lab's 400 steps: 0, 5 (after 6 to 16 s) and 2 of 6 upright."""
    import dataclasses

    import pendkit
    from pendkit.control.swingup import SwingUpController
    from pendkit.control.sysid import identify_servo_steps
    from pendkit.deploy import run_guarded
    from pendkit.features import time_to_upright_s
    from pendkit.network import IMPAIRMENTS
    from pendkit.sim.fidelity import FIDELITY_PRESETS
    from pendkit.sim.lab_readings import servo_step_readings
    from pendkit.sim.servo_fit import match_servo_speed

    params = pendkit.RigParams.preset("hitec-d645mw-4v8")
    video = servo_step_readings(steps_rad=(0.6,), hold_s=0.6, params=params)
    slew = identify_servo_steps(video.times_s, video.commanded_rad, video.arm_rad).slew_rate_rad_s
    identified = match_servo_speed(slew, steps_rad=(0.6,))
    rig_like = dataclasses.replace(FIDELITY_PRESETS["realistic"], network=IMPAIRMENTS["classroom-wifi"])

    def rig_twin(servo=params):
        return pendkit.make(action_mode="continuous", fidelity=rig_like, filter_coefficient=0.0, params=servo,
                            start="rest")

    ideal = pendkit.make(action_mode="continuous", fidelity="ideal", filter_coefficient=0.0, start="rest")
    designs = {"ideal": SwingUpController.for_env(ideal), "rig": SwingUpController.for_env(rig_twin()),
               "re-identified": SwingUpController.for_env(rig_twin(identified))}
    up = {name: [s for s in (time_to_upright_s(list(run_guarded(rig_twin(), design, lambda *reading: None,
                                                                 steps=400, seed=seed).trace.pendulum_from_upright_rad),
                                               0.06) for seed in range(6)) if s is not None]
          for name, design in designs.items()}
    assert round(identified.servo_speed_s_per_60deg, 3) == 0.338, identified  # the text quotes it
    assert len(up["ideal"]) == 0 and len(up["re-identified"]) == 2, up
    assert len(up["rig"]) == 5 and 5.5 < min(up["rig"]) and max(up["rig"]) < 16.5, up  # "after 6 to 16 s"
