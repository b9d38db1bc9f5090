"""What labs 07-10 state about their own runs is what the runs show: times as measured, figures from the cells'
own settings, the instructor notes' numbers, and a figure whose labels can be read."""

import math
import re
import textwrap
import types
from pathlib import Path

import nbformat
import numpy as np

from pendkit.adapt.plots import SHOWN
from pendkit.rig import RigParams

ROOT = Path(__file__).resolve().parents[2]


def cells(name: str) -> list[str]:
    return [cell.source for cell in nbformat.read(ROOT / "solutions" / name, as_version=4).cells]


def flat(text: str) -> str:
    return " ".join(text.split())


def longest_cell_s(lab: str) -> int:
    """The longest cell's time in docs/results/labs.md's table of labs 07-10 (its column's first ": N s")."""
    for line in (ROOT / "docs" / "results" / "labs.md").read_text().splitlines():
        if line.startswith(f"| {lab} "):
            return int(re.search(r": (\d+) s\b", line.split("|")[3]).group(1))
    raise AssertionError(f"no row for lab {lab}")


def results_table(header_start: str) -> list[list[str]]:
    """The rows (cells stripped) of docs/results/labs.md's table whose header row starts with `header_start`."""
    lines = (ROOT / "docs" / "results" / "labs.md").read_text().splitlines()
    start = next(k for k, line in enumerate(lines) if line.startswith(header_start))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip().strip("|").split("|")])
    return rows


def test_lab07_and_08_state_their_training_cells_times_as_measured():
    lab07, lab08 = (" ".join(flat(c) for c in cells(name)) for name in ("07_dqn.ipynb", "08_gru_rdqn.ipynb"))
    assert f"94 to {longest_cell_s('07')} s when it was busy" in lab07
    runs = results_table("| run | lab 08's cell")
    seconds = [int(row[1].split()[0]) for row in runs]
    loads = [float(x) for row in runs for x in row[3].split(",")]
    assert len(runs) == 3 and f"the cell took {min(seconds)} to {max(seconds)} s in three runs of seed 0" in lab08
    assert f"(load average {min(loads):.0f}-{max(loads):.0f})" in lab08
    assert all(("after 140 episodes" in r[4] and "no policy in 250" in r[4]) or "the same" in r[4] for r in runs)
    assert "the delay-aware DQN passed after 140 episodes, plain DQN ran its 250 without a check passing" in lab08


def test_lab07_reflection_2_quotes_its_realistic_runs_as_measured():
    rows = results_table("| seed | outcome in 150 episodes")
    text = " ".join(flat(c) for c in cells("07_dqn.ipynb"))
    seconds = [int(row[3]) for row in rows]
    returns = [int(row[2]) for row in rows]
    assert [row[0] for row in rows] == ["0", "1", "2"] and all(row[1].startswith("no policy") for row in rows)
    assert f"{min(seconds)} to {max(seconds)} s a seed in the kit's runs" in text
    assert "seeds 0, 1 and 2 each ended the 150 episodes without a policy that holds" in text
    assert f"between {min(returns)} and {max(returns)}" in text
    assert "TRY_REALISTIC = False" in next(c for c in cells("07_dqn.ipynb") if "realistic_run(" in c)


def test_lab07_policy_verdict_text_says_more_than_ten_is_not_the_rule():
    text = flat(cells("07_dqn.ipynb")[17])
    assert "exactly 10 episodes, 5 of each start" in text and "with more" in text


def test_lab07_q_value_figure_has_labels_that_do_not_overlap():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    source = cells("07_dqn.ipynb")[22]
    body = textwrap.dedent(source.split("if agent is not None:\n", 1)[1]).replace("plt.show()", "")
    n = 400  # a 24 s episode, the angle unwrapped over two turns: long tick labels
    namespace = {"np": np, "plt": plt, "agent": object(),
                 "q_along_greedy_episode": lambda env, agent: (np.linspace(-4 * np.pi, 0, n),
                                                               -np.linspace(400, 3, n), np.linspace(0.1, 9.5, n)),
                 "env": types.SimpleNamespace(unwrapped=types.SimpleNamespace(dt=0.06))}
    exec(body, namespace)  # noqa: S102 (the notebook's own plotting code)
    figure = plt.gcf()
    figure.canvas.draw()
    renderer = figure.canvas.get_renderer()
    boxes = [axis.yaxis.label.get_window_extent(renderer) for axis in figure.axes]
    plt.close(figure)
    assert len(boxes) == 3
    assert not any(a.overlaps(b) for k, a in enumerate(boxes) for b in boxes[k + 1:])


def test_lab08_plot_and_training_say_the_delay_the_students_function_gives():
    from pendkit.labs.delay_parts import delay_said, steps_late

    def right(observations, delay_steps):
        return np.asarray(observations)[np.maximum(0, np.arange(len(observations)) - delay_steps)]

    def one_short(observations, delay_steps):
        return right(observations, delay_steps - 1)

    assert steps_late(right, 2) == 2 and delay_said(right, 2, 0.06) is None
    assert steps_late(one_short, 2) == 1
    assert "shows them 1 step late (60 ms)" in delay_said(one_short, 2, 0.06)
    assert steps_late(lambda o, d: np.roll(o, d, axis=0), 2) is None
    assert "f\"seen {1000 * late * env.unwrapped.dt:.0f} ms late" in cells("08_gru_rdqn.ipynb")[10]


def test_lab08_note_quotes_the_gru_comparison_as_it_runs():
    """The instructor note's share of the GRU cell's run within 0.3 rad (seed 5, 500 steps) for the kit's cell and
    for each wrong cell it quotes, and how close the ones that never swing up come."""
    import pendkit
    from pendkit.episode import run_episode
    from pendkit.grading.suites.lab08 import reference_gru_step
    from pendkit.labs.delay_parts import policy_with_cell

    note = flat(cells("08_gru_rdqn.ipynb")[28])
    twin = pendkit.make(fidelity="realistic", action_mode="continuous", max_episode_steps=500)

    def angles(variant):
        cell = None if variant is None else (
            lambda x, h, a, b, c, d: reference_gru_step(np.asarray(x), np.asarray(h), a, b, c, d, variant))
        trace = run_episode(twin, policy_with_cell("r-dqn-levels-realistic", twin, cell), seed=5,
                            options={"start": "rest"})
        return np.abs(trace.pendulum_from_upright_rad)

    def share(variant):
        return f"{np.mean(angles(variant) < 0.3):.0%}"

    assert f"within 0.3 rad of upright {share(None)} of the time" in note
    assert f"outside the reset gate it is up {share('b_hn outside')} of the time" in note
    assert f"(the original paper's cell) {share('reset on h')}" in note
    for variant, said in (("z swapped", r"never swings up \(never within ([\d.]+) rad\)"),
                          ("update first", r"\(update, reset\) never within ([\d.]+) rad")):
        closest = float(re.search(said, note).group(1))
        got = angles(variant)
        assert np.mean(got < 0.3) == 0 and closest <= got.min() < closest + 0.1, (variant, got.min())


def test_lab10_measures_the_latency_for_as_long_as_it_says():
    source, text = cells("10_on_device.ipynb")[7], flat(cells("10_on_device.ipynb")[6])
    seconds = float(re.search(r"measure_latency_ms\(budget\(interactive=([\d.]+)", source).group(1))
    words = {2.0: "two", 3.0: "three", 4.0: "four", 5.0: "five"}
    assert f"its one-way latencies over {words[seconds]} seconds" in text


def test_lab10_note_quotes_the_estimates_error_as_the_cell_measures_it():
    """Lab 10's estimate cell (the realistic twin on the busy WiFi, seed 1, 60 steps from rest): the rate error's
    RMS with the right model, the range over the wrong models the note lists, and the flipped damping."""
    import dataclasses
    import math

    import pendkit
    from pendkit.deploy.on_twin import upload_to_twin
    from pendkit.deploy.swingup_design import design_swing_up
    from pendkit.device.controller_blob import pack
    from pendkit.grading.suites.lab10 import MISTAKES, reference
    from pendkit.network import IMPAIRMENTS
    from pendkit.sim.fidelity import FIDELITY_PRESETS

    fidelity = dataclasses.replace(FIDELITY_PRESETS["realistic"], network=IMPAIRMENTS["poor-wifi"])
    env = pendkit.make(fidelity=fidelity, action_mode="continuous", filter_coefficient=0.0)
    upload_to_twin(env, pack(design_swing_up(env.unwrapped.params, "energy")))
    backend = env.unwrapped.backend
    onboard = backend.device.mcu.onboard

    def rms(model) -> float:
        onboard.runtime.pendulum_acceleration = model
        env.reset(seed=1, options={"start": "rest"})
        error = []
        for _ in range(60):
            backend.step_with_message("h" if onboard.running else "k1")
            if onboard.running:
                error.append(onboard.runtime.rate_rad_s - backend.true_state()["pendulum_velocity_rad_s"])
        return float(np.sqrt(np.mean(np.square(error))))

    note = flat(cells("10_on_device.ipynb")[23])
    right = rms(lambda a, w, p, w0, d, k: reference(a, w, p, w0, d, k))
    assert f"({right:.2f} rad/s RMS with the right model" in note
    listed = [cause for cause in MISTAKES
              if "damping" not in cause and "is missing" not in cause and "lacks" not in cause]
    wrong = [rms(MISTAKES[cause]) for cause in listed] + [rms(lambda *args: 0.0)]
    assert f"; {min(wrong):.2f}-{max(wrong):.2f} with the arm's push" in note, wrong
    assert min(wrong) > 1.3 * right  # the cell says so for each
    flipped = rms(MISTAKES["the damping has the wrong sign (it slows the pendulum)"])
    assert f"a flipped damping sign hardly shows, {flipped:.2f}" in note
    missing = rms(next(model for cause, model in MISTAKES.items() if cause.startswith("the damping term is missing")))
    assert f"nor a missing damping term, {missing:.2f}, the bearing's damping being small" in note
    assert missing < 1.3 * right  # so the cell does not say so: the check cell names it
    no_gravity = rms(MISTAKES["gravity's term is missing: -w0^2 sin(angle)"])
    no_cos = rms(next(model for cause, model in MISTAKES.items() if "lacks its cos(angle)" in cause))
    assert (f"gravity left out reads {no_gravity:.2f} and a push without its cos(angle) {no_cos:.2f}, just below "
            "that line") in note
    assert max(no_gravity, no_cos) < 1.3 * right
    assert math.isfinite(flipped)


def test_lab09_quotes_the_rig_runs_as_docs_results_records_them():
    """The rig's real-time runs are not rerun by a test (a busy machine decides them): lab 09's student text says
    in words what every run docs/results/labs.md records supports (the kit's five and the walk-throughs'), so
    a new run does not fall outside a quoted range; the instructor note quotes the kit's five."""
    text = " ".join(flat(c) for c in cells("09_deploy.ipynb"))
    results = flat((ROOT / "docs" / "results" / "labs.md").read_text())
    rows = {row[0]: row[1:] for row in results_table("| lab 09 line | run 1 |")}

    def up_and_return(cell):
        up, total = cell.rsplit(", ", 1)
        return (None if up.startswith("-") else float(up.split()[0])), float(total), "stopped" in up

    ideal = [up_and_return(c) for c in rows["swing-up + LQR, on the rig"]]
    redesigned = [up_and_return(c) for name in ("re-identified, delay-aware, rig", "identified in 6 episodes, rig")
                  for c in rows[name]]
    # the design for the ideal twin: never up in the kit's five, nor in the walk-through that counted its returns
    assert all(up is None for up, _, _ in ideal)
    assert "the design for the ideal twin returned -1611.0 to -1794.3 and never came up" in results
    assert "the design for the ideal twin has not come up in any recorded run" in text
    # a redesign: from none in six (a walk-through's three right runs) to six in ten (the kit's five), early and late
    came = [up for up, _, _ in redesigned if up is not None]
    assert (len(came), len(redesigned)) == (6, 10) and min(came) < 8 and max(came) > 16
    assert "saw neither redesign come up on the rig in the three right runs (none in six lines" in results
    assert ("Either redesign (re-identified, or identified in Task 4) may come up, at any time in the run, or not: "
            "in the recorded runs, from none in six on one laptop to six in ten on another") in text
    kept = [total for _, total, stopped in redesigned if not stopped]
    ideal_returns = [total for _, total, _ in ideal]
    assert max(ideal_returns) < min(kept)  # usually: every one of the kit's five, all but one in two walk-throughs
    assert "a redesign returned more than that run's ideal-twin design in 11 of 12 lines" in results
    assert "the re-identified design returned -1694.3 against that run's ideal-twin design's -1641.0" in results
    assert "often returns more than the design for the ideal twin even when it does not come up, but not always" in text
    assert 'marks it "stopped". Its return covers only the run before the stop, so leave it out' in text
    assert "returned -1693.6 against that run's ideal-twin design's -1611.0" in results
    assert (f"they came up in {len(came)} of {len(redesigned)} runs in the kit's latest five (at {min(came):.1f} to "
            f"{max(came):.1f} s of 24 s; walk-throughs saw them from 2.6 s)") in text
    assert "saw the re-identified design come up on the rig at 6.06, 2.64 and 2.70 s" in results
    # the identification: the nominal twin's gap about 0.03; a right cost under half; the ranges overlap
    nominal = [float(x) for x in rows["nominal twin's gap (rad^2)"]]
    assert all(0.025 <= n <= 0.036 for n in nominal) and "twin's (the figure's *prior*) is about 0.03 rad^2" in text
    # the watchdog's hold after the drop and its reading's age (the fifteenth walk-through's runs)
    assert "held the rig 0.36, 0.30, 0.36 and 0.36 s after the drop on readings 0.352, 0.307, - and 0.357 s old" \
        in results
    gaps = [held - age for held, age in ((0.36, 0.352), (0.30, 0.307), (0.36, 0.357))]
    assert max(map(abs, gaps)) < 0.05 and min(gaps) < 0 < max(gaps)
    assert "The two agree to a few hundredths of a second, either one the larger" in text
    walked_nominal = [0.0404, 0.0283, 0.0338, 0.0288, 0.0435, 0.0284]  # the fifteenth's and sixteenth's runs
    assert "the nominal twin's gap 0.0404, 0.0283, 0.0338 and 0.0288 rad^2" in results
    recorded = nominal + walked_nominal
    low, high = math.floor(min(recorded) * 1000) / 1000, math.ceil(max(recorded) * 1000) / 1000  # covering them all
    assert f"(the figure's *prior*) is about 0.03 rad^2 ({low:.3f} to {high:.3f} in recorded runs)" in text
    assert max(recorded) < 0.045 and "above 0.045 rad^2, run the cell again" in text  # every one under the re-run line
    # the identified values move from run to run (the eighth walk-through's runs), the gap fraction less
    assert ("the servo's speed 0.280 to 0.389 s/60 deg, the latency 19.7 to 34.8 ms and the stall torque 9.96 to "
            "25.58 kg cm, while the identified twin's gap stayed within 0.05 to 0.13") in results
    assert 25.58 / 9.96 > 1.5 and 34.8 / 19.7 > 1.5  # "by half or more between two runs"
    assert "error; a servo that never strains against its load hardly shows its torque) by half or more." in text
    # the gap fraction moves too: the sixteenth walk-through's busy and quiet runs
    assert "its twin's gap 0.0200 against the nominal twin's 0.0435 (a fraction of 0.46)" in results
    assert "0.0025 against 0.0284 (0.09)" in results and round(0.0200 / 0.0435, 2) == 0.46
    assert "The gap fraction moves too (0.46 and 0.09 in two runs on one laptop)" in text
    assert "a right cost 0.03 to 0.46 in the walk-throughs" in text  # the instructor note's range
    assert 0.389 / 0.280 > 4 / 3 and "the servo's speed can move by a third or more" in text
    # the pendulum's: the twelfth walk-through's two right runs
    assert "its pendulum's frequency read 5.283 and 5.377 rad/s" in results and 5.377 / 5.283 < 1.05
    assert "Between two runs the pendulum's length and frequency stay within a few percent" in text
    assert "bearing damping read 0.001541 and 0.001419 (8 % apart)" in results and 0.001541 / 0.001419 < 1.1
    assert "(its bearing damping within about a tenth)" in text
    # no one identified value predicts the Task 4 count: the nineteenth walk-through's two right runs
    assert "designs come up from 4 of 6 with the latency read at 20.06 ms and from none at 14.44 ms" in results
    assert "(one student's design came up from 4 of 6 at 20.1 ms and from none at 14.4 ms)" in text
    assert "took 53, 53 and 45 s of rig time" in results and "in under a minute of its time" in text
    # the identification figure: the first SHOWN episodes, each titled "episode k of N"
    assert SHOWN == 3 and "the figure shows the first three recorded swings" in text
    # the Task 4 design over many starts: the study's five identifications
    study = results_table("| run | identified servo (s/60 deg) |")
    counts = [int(row[3]) for row in study]
    assert sorted(counts) == [0, 2, 2, 4, 4] and "it came up from 0, 2, 2, 4 and 4 of 6" in text
    assert 2 <= sum(counts) / len(counts) < 3 and "about as often as the re-identified design's 2 on average" in text
    # why: the latency and the servo each read loosely (the study's last two columns)
    latency = [float(row[2]) for row in study]
    rig_at_latency = [int(row[5]) for row in study]
    worst = latency.index(max(latency))
    rest = [n for k, n in enumerate(rig_at_latency) if k != worst]
    assert rig_at_latency[worst] == 0 and sorted(set(rest)) == [4, 5]
    assert (f"came up from none of 6 where that latency was {max(latency):.1f} ms, and from 4 or 5 where it was "
            f"{min(latency):.1f} to {sorted(latency)[-2]:.1f} ms") in text
    assert all(rig >= own for rig, own in zip(rig_at_latency, counts))
    assert "at each latency it came up at least as often as the identified servo did" in text
    # Task 4 reads the servo no closer than the step fit, in the recorded runs
    assert "read the servo at 0.188, 0.320, 0.287 and 0.390 s/60 deg" in results and "0.2845 and 0.3135" in results
    assert "0.392, 0.353, 0.329 and 0.230 s/60 deg" in results  # the fifteenth walk-through's
    assert "identified the servo at 0.0958 s/60 deg" in results and "at 0.274 s/60 deg and 12.6 ms" in results
    speeds = [0.188, 0.320, 0.287, 0.390, 0.392, 0.353, 0.329, 0.230, 0.0958, 0.274]
    assert ("not always closer: six short episodes pin the servo loosely (recorded runs read it from about "
            f"{min(speeds):.1f} to {max(speeds):.1f} s/60 deg)") in text
    # the thirteenth to nineteenth walk-throughs' Task 4 designs, of 6
    walked = [3, 1, 5, 3, 1, 3, 2, 0, 6, 0, 1, 2, 0, 0, 1, 3, 4, 0]
    assert "designs came up from 3 and 1 of 6" in results and "designs up from 5, 3, 1 and 3 of 6" in results
    assert "its Task 4 designs came up from 2, 0, 6 and 0 of 6" in results
    assert "from 1 and 2 of 6 starts on the twin of the rig" in results
    assert "saw its Task 4 designs come up from none of 6 in both right runs" in results
    assert (min(walked), max(walked)) == (0, 6) and "virtual rig saw anything from none to all 6" in text
    assert "the identified damping ratio read 0.78 and 0.19, the full-torque error 4.33 and 8.80 deg" in results
    assert 0.78 / 0.19 > 1.5 and 8.80 / 4.33 > 1.5 and "its latency, stall torque, damping ratio and" in text
    # the step fit's error is named against the virtual rig's own servo, the preset the lab's rig is made of
    rig_line = next(line for c in cells("09_deploy.ipynb") for line in c.splitlines() if "LocalRig(" in line)
    preset = re.search(r'preset\("([^"]+)"\)', rig_line).group(1)
    speed = RigParams.preset(preset).servo_speed_s_per_60deg
    assert f"slower than the virtual rig's own {speed:.2f} s/60 deg" in text
    right = [float(g) / n for g, n in zip(rows["identified twin's gap, the right cost"], nominal)]
    no_wrap = [float(g) / n for g, n in zip(rows["the same recordings, a cost without the wrap"], nominal)]
    assert max(right) < 0.5 and "right-cost fractions of 0.31 (0.0094 against 0.0301)" in results
    assert min(no_wrap) < 0.31  # a cost without the wrap below a right cost's recorded fraction: they overlap
    assert "cost usually brings it under half" in text and "alone does not tell the two apart" in text
    # a stall: twice the same walk-through's other runs
    assert "at 0.0275-0.0299 rad^2 in four runs and at 0.0589 in one (load 3.6)" in results
    assert 1.8 < 0.0589 / 0.0299 and "(twice as high in one recorded run)" in text
    # td3-realistic on the rig: the earlier 20 runs, the walk-through's 5 and the kit's five
    td3 = [up_and_return(c)[0] for c in rows["td3-realistic, on the rig"]]
    assert "4 of 20 in all" in results
    assert "`td3-realistic` come up on the rig in 2 of 5 (6.66 s and 20.16 s)" in results
    total_up, total = 4 + 2 + sum(u is not None for u in td3), 20 + 5 + len(td3)
    assert f"came up on the rig in {total_up} of {total} runs in all, at 2.8 to 20.2 s" in results
    assert 0.1 <= total_up / total <= 0.3 and "`td3-realistic` comes up in about one run in five" in text
    assert f"came up in {total_up} of {total} runs of the cell's sequence (at 2.8 to 20.2 s;" in text
    # the excitation's rig time (the note: 50 to 56 s, with the earlier runs' 55 and 56 s)
    rig_s = [int(c.split()[0]) for c in rows["excitation: rig time; the identification cell"]]
    cell_s = [int(c.split("; ")[1].split()[0]) for c in rows["excitation: rig time; the identification cell"]]
    assert f"are {min(rig_s)} to 56 s of a rig's time" in text and "(runs B and D: 56 s)" in results
    assert f"the cell took {min(cell_s)} to {max(cell_s)} s in the kit's latest five runs" in text
