"""Matching on the device's clock: recordings that keep every reading with the device's time and applied
servo target let the twin be replayed through a WiFi that blurs the host's step-by-step view."""

import dataclasses

import numpy as np
import pytest

from pendkit.adapt.excitation import EXCITATION_STREAM, Excitation, Recording, record, schedule
from pendkit.adapt.identify import Identification, identify, matching_cost, measured_latency_ms, refine_servo
from pendkit.adapt.replay import replay_cost
from pendkit.adapt.rigs import twin_rig
from pendkit.network import IMPAIRMENTS, LatencyModel, NetworkImpairment, median_latency_ms
from pendkit.rig import RigParams

HIDDEN = dataclasses.replace(RigParams.preset("mks-x5-hbl550"), dowel_length_m=0.34,
                             dowel_mass_kg=RigParams().dowel_mass_kg * 0.34 / 0.4)


def logged_recordings(params, network, log_dir, episodes=2):
    rig = twin_rig(params, network)
    env = rig.make_env(stream=EXCITATION_STREAM, log_dir=str(log_dir), **Excitation.env_kwargs())
    recordings = [record(env, e, seed=k) for k, e in enumerate(schedule(episodes))]
    env.close()
    return recordings


def test_the_replayed_twin_follows_a_rig_through_poor_wifi_where_the_step_by_step_match_cannot(tmp_path):
    network = IMPAIRMENTS["poor-wifi"]
    recordings = logged_recordings(HIDDEN, network, tmp_path)
    # the twin's PWM frames fall on whole multiples of 20 ms of its device's clock: phase 0
    own = replay_cost(HIDDEN, 0.0, recordings)
    assert own < 1e-3
    assert replay_cost(RigParams(), 0.0, recordings) > 10 * own  # the replay tells the rigs apart
    slower = dataclasses.replace(HIDDEN, servo_speed_s_per_60deg=1.5 * HIDDEN.servo_speed_s_per_60deg)
    assert replay_cost(slower, 0.0, recordings) > 5 * own
    stepwise = matching_cost(HIDDEN, median_latency_ms(network.latency), recordings)
    assert stepwise > 3 * own  # the host's own view, with the rig's true parameters and its median latency


def test_a_recording_keeps_every_reading_of_its_episode_and_survives_json(tmp_path):
    recording = logged_recordings(RigParams(), "none", tmp_path, episodes=1)[0]
    trace = recording.device
    steps = len(recording.actions)
    assert abs(len(trace.ms) - 1 - steps * 60 / 10) <= 2  # a reading every 10 ms for the whole episode
    assert np.all(np.diff(trace.ms) > 0)
    targets = [a for k, a in enumerate(recording.actions) if k == 0 or a != recording.actions[k - 1]]
    assert len(trace.changes()) == len(targets) == len(trace.loops_ms)  # a lossless link: every change shows
    again = Recording.from_dict(recording.as_dict())
    assert again == recording


def test_the_timed_loops_give_the_simulated_links_latency(tmp_path):
    # the twin's clock is simulated: its 30 ms link is the same however busy the machine
    network = NetworkImpairment(LatencyModel(floor_ms=30.0))
    recordings = logged_recordings(RigParams(), network, tmp_path)
    assert measured_latency_ms(recordings, RigParams()) == pytest.approx(30.0, abs=6.0)


def test_without_a_log_identification_matches_the_hosts_steps(tmp_path):
    rig = twin_rig(RigParams(), "none")
    env = rig.make_env(**Excitation.env_kwargs())
    recordings = [record(env, schedule(1)[0])]
    assert recordings[0].device is None
    found = identify(recordings, RigParams(), max_evaluations=40)
    assert found.pwm_phase_ms is None
    assert found.cost == pytest.approx(matching_cost(found.params, found.latency_ms, recordings))  # step by step
    assert found.evaluations <= 40  # a small budget (lab 09 under CI) is kept, not spent twice over
    assert found.cost <= found.prior_cost


@pytest.mark.expensive
def test_identification_on_the_device_clock_reads_a_hidden_servo_through_poor_wifi(tmp_path):
    hidden = RigParams.preset("hitec-hsb-9380th").with_dowel_length(0.42)  # an underdamped servo loop (0.2)
    recordings = logged_recordings(hidden, IMPAIRMENTS["poor-wifi"], tmp_path, episodes=6)
    # seed 0's search; seeds 1 and 2 settle in worse fits that misread the damping (docs/results/test-suite.md)
    found = identify(recordings, RigParams(), max_evaluations=600)
    assert found.pwm_phase_ms is not None  # matched on the device's clock
    assert found.cost < found.prior_cost / 10  # angle errors (rad^2), not times
    assert found.params.servo_speed_s_per_60deg == pytest.approx(hidden.servo_speed_s_per_60deg, rel=0.1)
    assert found.params.pendulum_natural_frequency_rad_s == pytest.approx(
        hidden.pendulum_natural_frequency_rad_s, rel=0.03)
    assert abs(found.params.servo_damping_ratio - hidden.servo_damping_ratio) <= 0.15  # the prior says 0.7


def test_the_loop_episodes_show_a_slow_servos_loop_that_the_big_jumps_hide(tmp_path):
    """On a slow servo the big jumps are ramps at its speed limit, and its loop hardly shows in them. A loop
    twice as stiff or as soft moves the replayed pendulum far more after the small quick steps, so a fit has
    the loop's stiffness to go on (docs/rl.md)."""
    slow = RigParams.preset("hitec-d645mw-4v8")
    rig = twin_rig(slow, IMPAIRMENTS["classroom-wifi"])
    env = rig.make_env(stream=EXCITATION_STREAM, log_dir=str(tmp_path), **Excitation.env_kwargs())
    episodes = schedule(3, loop_episodes=3)
    recorded = [record(env, e, seed=k) for k, e in enumerate(episodes)]
    env.close()
    assert all(r.device is not None for r in recorded)
    jumps, loop = recorded[:3], recorded[3:]
    assert max(np.ptp(r.actions) for r in loop) < 0.3 < min(np.ptp(r.actions) for r in jumps)

    def rise(recordings, scale):
        changed = dataclasses.replace(slow, servo_full_torque_error_deg=slow.servo_full_torque_error_deg * scale)
        return replay_cost(changed, 0.0, recordings) - replay_cost(slow, 0.0, recordings)

    for scale in (0.5, 2.0):
        assert rise(loop, scale) > 3 * max(rise(jumps, scale), 1e-7)


def test_refining_the_servo_over_the_loop_episodes_mends_a_loop_the_jumps_misread(tmp_path):
    """A fit whose loop is read twice too stiff (what the big jumps alone leave open on a slow servo) is
    moved back towards the rig's loop by `refine_servo` over the jumps and the loop episodes together, and
    never ends a worse match than it started."""
    slow = RigParams.preset("hitec-d645mw-4v8")
    rig = twin_rig(slow, IMPAIRMENTS["classroom-wifi"])
    env = rig.make_env(stream=EXCITATION_STREAM, log_dir=str(tmp_path), **Excitation.env_kwargs())
    recorded = [record(env, e, seed=k) for k, e in enumerate(schedule(2, loop_episodes=3))]
    env.close()
    true_error = slow.servo_full_torque_error_deg
    misread = dataclasses.replace(slow, servo_full_torque_error_deg=true_error / 2)
    # the twin's PWM frames start on the device's clock: phase 0, as the jumps' fit reads it
    fit = Identification(misread, 10.0, cost=1.0, prior_cost=1.0, evaluations=5, seconds=0.0, pwm_phase_ms=0.0)
    refined = refine_servo(fit, recorded, RigParams(), max_evaluations=120)
    assert refined.cost <= replay_cost(misread, 0.0, recorded)
    assert refined.evaluations > fit.evaluations
    error = refined.params.servo_full_torque_error_deg
    assert abs(np.log(error / true_error)) < 0.5 * abs(np.log(0.5))  # at least half the way back, in log scale
    assert refined.params.pendulum_natural_frequency_rad_s == slow.pendulum_natural_frequency_rad_s  # kept
