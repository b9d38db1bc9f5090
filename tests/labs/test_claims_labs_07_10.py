"""What labs 07-10 state about their own runs is what the runs show: times as measured, figures from the cells'
own settings, the instructor notes' numbers, and a figure whose labels can be read."""

import re
import textwrap
import types
from pathlib import Path

import nbformat
import numpy as np

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


def test_lab07_and_08_state_their_training_cells_times_as_measured():
    lab07, lab08 = (" ".join(flat(c) for c in cells(name)) for name in ("07_dqn.ipynb", "08_gru_rdqn.ipynb"))
    assert f"94 to {longest_cell_s('07')} s when it was busy" in lab07
    assert f"the cell took 138 to {longest_cell_s('08')} s for seed 0" in lab08


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
    listed = [cause for cause in MISTAKES if "damping" not in cause]
    wrong = [rms(MISTAKES[cause]) for cause in listed] + [rms(lambda *args: 0.0)]
    assert f"; {min(wrong):.2f}-{max(wrong):.2f} with the arm's push" in note, wrong
    assert min(wrong) > 1.3 * right  # the cell says so for each
    flipped = rms(MISTAKES["the damping has the wrong sign (it slows the pendulum)"])
    assert f"a flipped damping sign hardly shows, {flipped:.2f}" in note
    assert math.isfinite(flipped)


def test_lab09_quotes_the_rig_runs_as_docs_results_records_them():
    """The rig's real-time runs are not rerun by a test (a busy machine decides them): lab 09's text quotes the
    runs docs/results/labs.md records (the counts and the gaps on the identification's recordings)."""
    text = " ".join(flat(c) for c in cells("09_deploy.ipynb"))
    results = flat((ROOT / "docs" / "results" / "labs.md").read_text())
    assert "in 4 of 20 runs of this cell's sequence" in text and "4 of 20 in all" in results
    assert "at 2.8 to 7.7 s" in text and "2.82 s" in results and "7.74 s" in results
    for gap in ("0.0020", "0.0289", "0.0038", "0.0322", "0.0104"):
        assert gap in text and gap in results, gap
    assert "come up at 4.4, 9.1 and 14.9 s" in text and "4.44, 9.06 and 14.94 s" in results
