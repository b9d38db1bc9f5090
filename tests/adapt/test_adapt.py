"""`pendkit adapt`'s pieces on hidden twins: excitation that stays short of a swing-up and reads only what a
rig reports, a matching cost that singles out the rig's own parameters, a first stage that reads the
pendulum from its free swings, and the whole session writing its report with rig time counted by the rig."""

import dataclasses
import json

import numpy as np
import pytest

import pendkit
from pendkit.adapt.excitation import (
    ADAPT_FREE_STEPS,
    LOOP_DRIVE_STEPS,
    LOOP_FREE_STEPS,
    REST_STEPS,
    Excitation,
    NotAtRest,
    hold_until_at_rest,
    record,
    schedule,
)
from pendkit.adapt.identify import identify, identify_best, matching_cost, simulate, simulate_all, swing_estimates
from pendkit.adapt.rigs import twin_rig
from pendkit.device.controller_blob import parse
from pendkit.encoder import wrapped_rad
from pendkit.errors import ConfigError
from pendkit.rig import RigParams

pytestmark = pytest.mark.expensive  # the full tier (`pytest --full`): adaptation sessions (identification, trials)

HIDDEN = dataclasses.replace(RigParams.preset("hitec-d645mw-4v8"), dowel_length_m=0.34,
                             dowel_mass_kg=RigParams().dowel_mass_kg * 0.34 / 0.4)


def recordings(params, episodes=3, impairment="none"):
    rig = twin_rig(params, impairment)
    env = rig.make_env(**Excitation.env_kwargs())
    return [record(env, e, seed=k) for k, e in enumerate(schedule(episodes))], rig


def test_excitation_swings_the_pendulum_clearly_but_short_of_the_top_and_counts_rig_time():
    recs, rig = recordings(RigParams(), episodes=4)
    for r in recs:
        swing = np.abs(np.angle(np.exp(1j * np.asarray(r.pendulum_rad))))
        assert 0.2 < swing.max() < 2.0  # visible, and well below horizontal-and-over
    assert rig.seconds() == pytest.approx(sum(r.rig_steps for r in recs) * 0.06)
    assert all(r.rest_steps == REST_STEPS - 1 for r in recs)  # a twin from rest: the check's steps only
    assert len({tuple(r.actions) for r in recs}) == 4  # every episode excites differently


def test_a_recording_waits_until_the_pendulum_hangs_still_and_gives_up_on_one_that_never_does():
    env = twin_rig(RigParams()).make_env(**Excitation.env_kwargs())
    _, info = env.reset(seed=0, options={"pendulum_angle_rad": 1.0})  # a run left it swinging
    state, steps = hold_until_at_rest(env, info["state"])
    assert steps > 50 and abs(wrapped_rad(state.pendulum_angle_rad)) < 0.03
    frictionless = dataclasses.replace(RigParams(), pendulum_damping_n_m_s_per_rad=0.0)
    env = pendkit.make(fidelity="ideal", params=frictionless, **Excitation.env_kwargs())
    _, info = env.reset(seed=0, options={"pendulum_angle_rad": 1.0})
    with pytest.raises(NotAtRest, match="stop it by hand"):
        hold_until_at_rest(env, info["state"])


def test_the_matching_cost_singles_out_the_rigs_own_parameters():
    recs, _ = recordings(HIDDEN)
    own = matching_cost(HIDDEN, 0.0, recs)
    prior = matching_cost(RigParams(), 10.0, recs)
    slower = matching_cost(dataclasses.replace(HIDDEN, servo_speed_s_per_60deg=0.4), 0.0, recs)
    assert own < 0.02 and prior > 5 * own and slower > 5 * own


def test_one_twin_reset_for_each_recording_simulates_what_a_new_twin_for_each_does():
    """A candidate's recordings share one twin (made once, reset each time): nothing of one recording's run
    (the arm's position, the device's state, the network's draws) may carry into the next."""
    recs, _ = recordings(HIDDEN)
    shared = simulate_all(HIDDEN, 12.0, recs)
    for recording, angles in zip(recs, shared):
        np.testing.assert_array_equal(angles, simulate(HIDDEN, 12.0, recording))
    assert not np.array_equal(shared[0][:len(shared[1])], shared[1][:len(shared[0])])  # each ends elsewhere


def test_of_several_fits_of_the_same_recordings_the_closest_match_is_kept():
    recs, rig = recordings(HIDDEN)
    fits = [identify(recs, rig.prior(), max_evaluations=40, seed=seed) for seed in (0, 1, 2)]
    best = identify_best(recs, rig.prior(), 40, seeds=(0, 1, 2))
    closest = min(fits, key=lambda fit: fit.cost)
    assert best.cost == closest.cost and best.params == closest.params and best.latency_ms == closest.latency_ms
    assert best.evaluations == sum(fit.evaluations for fit in fits)
    with pytest.raises(ConfigError, match="at least one seed"):
        identify_best(recs, rig.prior(), 40, seeds=())


def test_the_prior_takes_the_rigs_reported_end_counts_and_nothing_else():
    narrow = dataclasses.replace(HIDDEN, servo_min_counts=180, servo_max_counts=420)
    prior = twin_rig(narrow).prior()
    assert (prior.servo_min_counts, prior.servo_max_counts) == (180, 420)
    assert prior.servo_speed_s_per_60deg == RigParams().servo_speed_s_per_60deg
    assert prior.dowel_length_m == RigParams().dowel_length_m


def test_free_swings_read_a_shorter_pendulums_higher_frequency():
    short, _ = recordings(HIDDEN)
    default, _ = recordings(RigParams())
    ratio = swing_estimates(short, 0.06)[0] / swing_estimates(default, 0.06)[0]
    expected = HIDDEN.pendulum_natural_frequency_rad_s / RigParams().pendulum_natural_frequency_rad_s
    assert ratio == pytest.approx(expected, rel=0.05)


@pytest.mark.parametrize("loop_episodes, policy, measured, fine_tune", [
    (None, "r-dqn-realistic", False, True), (1, "r-dqn-levels-realistic", True, False)],
    ids=["fine-tuned", "loop-episode-target-levels-measured-network-excitation-alone"])
def test_an_adaptation_session_writes_rig_policy_and_report_within_its_rig_time(tmp_path, loop_episodes, policy,
                                                                                 measured, fine_tune):
    pytest.importorskip("torch")
    from pendkit.adapt.session import AdaptConfig, adapt
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack

    rig = twin_rig(HIDDEN, "none")
    looped = {} if loop_episodes is None else {"loop_episodes": loop_episodes, "refinement_evaluations": 12}
    config = AdaptConfig(episodes=2, excitation_episodes=2, twin_episodes=1, evaluation_episodes=1, candidates=(),
                         policy=policy, identification_evaluations=30, measured_network=measured,
                         fine_tune=fine_tune, **looped)
    report = adapt(rig, tmp_path, config, say=lambda text: None)
    identified = RigParams.load(tmp_path / "rig.json")
    assert identified != RigParams()  # something was identified
    assert (tmp_path / "policy.pt").exists() and (tmp_path / "identification.png").read_bytes()[:4] == b"\x89PNG"
    saved = json.loads((tmp_path / "report.json").read_text())
    # rig time as the rig counted it, within 2 episodes of 500 steps (60 s): 2 excitation episodes of 90 steps
    # and `loop_episodes` of the loop's small steps (60 each; none by default), each after the 7 steps that
    # find the pendulum still, no device trials (the default), and, fine-tuned, the one whole episode of 500
    # steps that fits in what is left
    assert saved["rig_s_trials"] == 0.0 and saved["device_trials"] == []
    loop_steps = LOOP_DRIVE_STEPS + LOOP_FREE_STEPS
    jump_steps = REST_STEPS - 1 + 12 + ADAPT_FREE_STEPS
    expected_steps = 2 * jump_steps + config.loop_episodes * (REST_STEPS - 1 + loop_steps) + (500 if fine_tune else 0)
    assert saved["rig_s_adaptation"] == pytest.approx(expected_steps * 0.06)
    assert saved["rig_s_adaptation"] <= saved["rig_s_budget"] == pytest.approx(2 * 500 * 0.06)
    assert saved["rig_s_total"] > saved["rig_s_adaptation"]  # the evaluation came after, on the same rig
    assert report["policy_on_rig"]["summary"].startswith("solved=")
    # the identified twin's two designs, each on the rig's device; the minimum-time one is what deploy takes
    assert set(report["classical_on_device"]) == {"energy", "trajopt"}
    assert all(len(o["solved"]) == 1 for o in report["classical_on_device"].values())
    assert saved["chosen_design"]["controller"] == "trajopt" and saved["chosen_design"]["trials"] == 0
    # the adapted policy run by the rig's device too, when the device runs its learner (R-DQN: layout 1)
    if policy == "r-dqn-realistic":
        assert len(report["policy_on_device"]["solved"]) == 1 and saved["device_policy_blob"] == "device-policy.pkcb"
        assert parse((tmp_path / "device-policy.pkcb").read_bytes()).kind == "policy"
    else:
        assert report["policy_on_device"] == {"summary": "not evaluated"}
    assert (tmp_path / saved["device_blob"]).read_bytes() == pack(design_swing_up(identified, "trajopt"))
    text = (tmp_path / "report.md").read_text()
    assert "| servo_speed_s_per_60deg |" in text and "run by the rig's own device" in text
    assert "without trials" in text and f"Deploy: {report['recommended'] or 'none of them'}" in text
    # the twin's training drew its rigs from what the recordings allow, each interval about the fit
    assert set(saved["uncertain"]) >= {"servo_speed_s_per_60deg", "servo_full_torque_error_deg", "dowel_length_m"}
    assert all(row["low"] < row["fit"] < row["high"] for name, row in saved["uncertain"].items()
               if name != "latency_ms")
    assert "the recordings allow" in text
    # asked for, the twin ran behind the network the excitation logs show (this rig's: a clean link)
    assert ("network" in saved) == measured and ("network the logs show" in text) == measured
    assert not measured or "0.0% lost" in saved["network"]
    # with loop episodes the servo is refined over them too, and the report says from what to what
    assert ("servo_refined" in saved) == bool(config.loop_episodes)
    if config.loop_episodes:
        assert saved["servo_refined"]["loop_episodes"] == config.loop_episodes
        assert saved["servo_refined"]["before"]["dowel_length_m"] == saved["identified"]["dowel_length_m"]
        assert f"refined over {config.loop_episodes} loop episodes" in text


def test_device_trials_when_asked_for_count_their_rig_time_and_choose_a_finalist():
    from pendkit.adapt.session import AdaptConfig, device_trials, trials_markdown
    from pendkit.adapt.trials import FINALISTS, trial_steps

    rig = twin_rig(HIDDEN, "none")
    report = {}
    chosen = device_trials(rig, HIDDEN, AdaptConfig(device_trials=True), 300.0, 0.06, report, lambda _: None)
    assert report["rig_s_trials"] == pytest.approx(trial_steps() * 0.06) == pytest.approx(rig.seconds())
    assert sum(d["trials"] for d in report["device_trials"]) == len(report["device_trials"]) + FINALISTS
    assert report["chosen_design"]["trials"] == 2 and report["chosen_design"]["whole_solved"] is not None
    assert len(chosen.trials) == 2 and chosen.blob is not None
    report.update(device_blob="device-controller.pkcb", classical_on_device={})
    assert trials_markdown(report).startswith("Device trials")


def test_device_trials_are_left_out_when_they_do_not_fit_the_rig_time_left():
    from pendkit.adapt.session import AdaptConfig, device_trials

    rig = twin_rig(HIDDEN, "none")
    said, report = [], {}
    assert device_trials(rig, HIDDEN, AdaptConfig(device_trials=True), 60.0, 0.06, report, said.append) is None
    assert report["rig_s_trials"] == 0.0 and rig.seconds() == 0.0 and "s are left" in said[0]


def test_without_trials_the_device_gets_the_identified_twins_minimum_time_design_and_no_rig_time_goes():
    from pendkit.adapt.session import AdaptConfig, device_trials, trials_markdown
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack

    rig = twin_rig(HIDDEN, "none")
    said, report = [], {}
    chosen = device_trials(rig, HIDDEN, AdaptConfig(), 300.0, 0.06, report, said.append)
    assert chosen.blob == pack(design_swing_up(HIDDEN, "trajopt")) and chosen.label == "identified"
    assert rig.seconds() == 0.0 and report["device_trials"] == [] and not chosen.trials
    report["device_blob"] = "device-controller.pkcb"
    assert "without trials" in trials_markdown(report) and "without trials" in said[0]


def _outcome(solved, upright_s):
    return {"solved": solved, "upright_s": upright_s, "summary": "..."}


def test_the_report_recommends_the_route_that_solved_most_then_the_quicker():
    from pendkit.adapt.session import recommended_route

    none = _outcome([False] * 3, [None] * 3)
    report = {"policy_on_rig": _outcome([True, False, False], [2.0, None, None]),
              "classical_on_rig": {"energy": none, "trajopt": _outcome([True, True, True], [4.0, 4.2, 4.1])},
              "classical_on_device": {"energy": _outcome([True, True, True], [2.5, 2.4, 2.6]), "trajopt": none}}
    assert recommended_route(report) == "energy swing-up + LQR on the rig's device"  # 3/3, and quicker
    report["classical_on_device"]["energy"] = _outcome([True, True, False], [1.0, 1.0, None])
    assert recommended_route(report) == "minimum-time swing-up (laptop)"  # more solved beats quicker
    report["classical_on_device"]["tried"] = _outcome([True, True, True], [4.1, 4.0, 4.2])
    assert recommended_route(report) == "the device design chosen by the trials"  # a tie on both goes to it
    failed = {"policy_on_rig": {"summary": "not evaluated"}, "classical_on_rig": {"energy": none, "trajopt": none},
              "classical_on_device": {"energy": none, "trajopt": none}}
    assert recommended_route(failed) is None


def test_a_rig_over_mqtt_reports_the_commands_it_received():
    import pendkit
    from pendkit.adapt.rigs import mqtt_rig, rig_status
    from pendkit.link.virtual_rig import LocalRig

    local = LocalRig()
    try:
        assert rig_status(local.rig, local.url).get("commands_received") == 0  # nothing sent yet
        env = pendkit.make(backend="rig", broker=local.url, rig=local.rig, rig_options={"reset_stop_s": 0.2})
        env.reset(seed=0)
        for _ in range(10):
            env.step(0)
        env.close()
        status = rig_status(local.rig, local.url)
        assert status["commands_received"] >= 10 and status["commands_received"] == local.virtual.commands_received
        assert mqtt_rig(local.rig, local.url).seconds() == pytest.approx(local.virtual.busy_s, abs=0.5)
    finally:
        local.stop()


def test_a_rig_over_mqtt_runs_a_short_device_trial_of_the_length_asked():
    from pendkit.adapt.rigs import mqtt_rig
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack
    from pendkit.link.virtual_rig import LocalRig

    local = LocalRig()
    try:
        runs = mqtt_rig(local.rig, local.url).run_on_device(pack(design_swing_up(RigParams(), "energy")), 1, 25)
        assert len(runs) == 1 and len(runs[0]) == 26  # the angle at the start, then one per step
        assert np.ptp(runs[0]) > 0.05  # the device's swing-up moved the pendulum: it ran, from rest
        assert local.virtual.commands_received >= 25
    finally:
        local.stop()


def test_adapt_moves_the_encoders_zero_to_where_the_pendulum_hung_still():
    from pendkit.adapt.identify import Identification
    from pendkit.adapt.session import recalibrated
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack

    rig = twin_rig(RigParams(), "classroom-wifi", residual_offset_counts=-5)  # the calibration missed 5 counts
    env = rig.make_env(**Excitation.env_kwargs())
    recs = [record(env, e, seed=k) for k, e in enumerate(schedule(2))]
    env.close()
    report = {}
    found = recalibrated(rig, recs, Identification(RigParams(), 10.0, 0.0, 0.0, 0, 0.0), report, lambda _: None)
    assert report["encoder_recalibrated_counts"] == -5  # read from the hanging pendulum, not from the rig's params
    assert found.params.encoder_offset_counts == 1024 - 5  # rig.json keeps the calibration for later sessions
    env = rig.make_env(**Excitation.env_kwargs())
    _, info = env.reset(seed=0)
    assert info["state"].pendulum_angle_rad == 0.0  # hanging now reads hanging
    env.close()
    start = rig.run_on_device(pack(design_swing_up(RigParams(), "energy")), 1, 5)[0][0]
    assert abs(start) == pytest.approx(np.pi)  # and so does the device's own controller


def test_a_rig_over_mqtt_is_recalibrated_for_its_envs_and_its_device_runs():
    from pendkit.adapt.rigs import mqtt_rig
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack
    from pendkit.link.virtual_rig import LocalRig

    local = LocalRig(mount_offset_counts=4)  # the encoder's zero sits 4 counts from where the kit assumes
    try:
        rig = mqtt_rig(local.rig, local.url)

        def hanging_reads_rad():
            env = rig.make_env(**Excitation.env_kwargs())
            _, info = env.reset(seed=0)
            env.close()
            return float(wrapped_rad(info["state"].pendulum_angle_rad))

        assert hanging_reads_rad() == pytest.approx(4 * 2 * np.pi / 1024)
        rig.recalibrate(4)
        assert hanging_reads_rad() == pytest.approx(0.0)
        start = rig.run_on_device(pack(design_swing_up(RigParams(), "energy")), 1, 5)[0][0]
        assert abs(start) == pytest.approx(np.pi)
    finally:
        local.stop()


def test_a_learned_policy_keeps_the_observer_it_was_trained_with():
    from pendkit.adapt.routes import policy_observer
    from pendkit.agents.runs import RunSpec
    from pendkit.rig import RigParams

    identified = type("Fit", (), {"params": RigParams(arm_mass_kg=0.2)})()
    told = RunSpec("td3+estimated", "realistic", observer="rig")
    nominal = RunSpec("r-td3+both", "realistic")
    assert policy_observer(told, identified).arm_mass_kg == 0.2
    assert policy_observer(nominal, identified) == RigParams()
    from pendkit.sim.randomize import observer_bank

    bank = policy_observer(RunSpec("r-td3+both", "realistic", observer="bank"), identified)
    assert bank == (identified.params, *observer_bank())  # what identification found joins the bank, first


def test_a_learner_afresh_trains_on_the_identified_twin_until_the_rule_holds_there(tmp_path, monkeypatch):
    import pendkit.agents.policy_rule as rule
    from pendkit.adapt.identify import Identification
    from pendkit.adapt.routes import train_on_twin
    from pendkit.adapt.session import AdaptConfig
    from pendkit.agents.data_files import load_data

    fit = Identification(dataclasses.replace(HIDDEN, arm_mass_kg=0.2), 25.0, 0.01, 0.1, 10, 1.0)
    judged = []

    def the_rule(probe, agent, inputs, seed, **options):  # what the check saw; says the policy holds
        base = probe.unwrapped
        assert inputs.reset(probe.reset(seed=seed)[0]).shape == (inputs.dim,)  # inputs the probe's policy reads
        judged.append((base.params, base._observer_design[0], base.backend.fidelity.network.latency.floor_ms))
        return type("Verdict", (), {"solved": True})()

    monkeypatch.setattr(rule, "judge_policy", the_rule)
    said = []
    run = train_on_twin(fit, AdaptConfig(policy="td3+estimated", twin_episodes=1), tmp_path / "policy.pt", said.append)
    assert judged == [(fit.params, fit.params, 25.0)]  # the rule judged on the identified twin, its observer
    assert run.observer_params == fit.params and "afresh" in said[0]
    saved = load_data(tmp_path / "policy.pt")
    assert saved["notes"]["twin_episodes"] == 1 and saved["spec"]["observer"] == "rig"


def test_of_several_starting_policies_the_one_that_holds_on_the_identified_twin_goes_to_the_rig(tmp_path):
    """Judged by the kit's rule on the identified twin (here the default rig, exactly): dqn-ideal, trained
    on a twin without delays, loses it; td3-realistic holds it and is chosen though named second."""
    from pendkit.adapt.candidates import choose_on_twin
    from pendkit.adapt.identify import Identification
    from pendkit.adapt.session import AdaptConfig, candidates_markdown
    from pendkit.agents.data_files import load_data
    from pendkit.agents.pretrained import policy_weights

    fit = Identification(RigParams(), 10.0, 0.01, 0.1, 10, 1.0)
    config = AdaptConfig(policy="dqn-ideal", candidates=("td3-realistic",), twin_episodes=0)
    said = []
    run, rows, device_run = choose_on_twin(fit, config, tmp_path / "policy.pt", said.append)
    held = {row["policy"]: row["held"] for row in rows}
    assert [row["stage"] for row in rows] == ["as shipped", "as shipped"] and all(r["episodes"] == 10 for r in rows)
    assert held["td3-realistic"] >= 9 > held["dqn-ideal"], rows
    assert run.spec.learner == policy_weights("td3-realistic")[0].learner and "td3-realistic" in said[-1]
    saved = load_data(tmp_path / "policy.pt")
    assert saved["notes"]["chosen_on_twin"] == "td3-realistic as shipped"
    assert "| td3-realistic | as shipped |" in candidates_markdown({"candidates_on_twin": rows})
    assert device_run is None and all(row["held_on_device"] is None for row in rows)  # the device runs neither
    with pytest.raises(ConfigError, match="not a shipped policy"):
        choose_on_twin(fit, AdaptConfig(candidates=("td3+estimated",)), tmp_path / "p.pt", said.append)


def test_the_rigs_device_gets_the_candidate_it_runs_even_when_the_laptop_chose_another(tmp_path):
    """td3-realistic holds the identified twin from the laptop, but the device does not run TD3; the R-DQN it
    runs is judged there (the rule's 10 starts, its blob on the identified twin's device) and goes to it."""
    from pendkit.adapt.candidates import choose_on_twin
    from pendkit.adapt.identify import Identification
    from pendkit.adapt.session import AdaptConfig, candidates_markdown

    fit = Identification(RigParams(), 10.0, 0.01, 0.1, 10, 1.0)
    config = AdaptConfig(policy="r-dqn-realistic", candidates=("td3-realistic",), twin_episodes=0)
    said = []
    run, rows, device_run = choose_on_twin(fit, config, tmp_path / "policy.pt", said.append)
    on_device = {row["policy"]: row["held_on_device"] for row in rows}
    assert run.spec.learner == "td3+estimated" and device_run.spec.learner == "r-dqn"
    assert on_device["td3-realistic"] is None and 0 <= on_device["r-dqn-realistic"] <= 10
    assert "chosen for the rig's device: r-dqn-realistic as shipped" in said[-1]
    assert f"| {on_device['r-dqn-realistic']}/10 |" in candidates_markdown({"candidates_on_twin": rows})
