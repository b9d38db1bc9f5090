"""Sweep specs: what a spec expands to, and the errors a wrong one gets (no Ray needed)."""

import json

import pytest

from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.sweep.report import delay_sweep_record, summary_lines
from pendkit.sweep.spec import load_spec, parse_spec
from pendkit.sweep.trial import run_spec_and_params


def test_a_spec_expands_to_learners_times_settings_times_seeds_in_a_stable_order(tmp_path):
    RigParams.preset("mks-x5-hbl550").save(tmp_path / "fast.json")
    (tmp_path / "grid.toml").write_text('name = "grid"\nlearners = ["dqn", "r-dqn"]\nfidelities = ["ideal"]\n'
                                       'rigs = ["fast.json"]\nseeds = [3, 4]\n[budget]\nmax_episodes = 30\n')
    spec = load_spec(tmp_path / "grid.toml")
    assert len(spec.trials) == 2 * 2 * 2
    assert [t.trial_id for t in spec.trials[:3]] == ["dqn--ideal--seed3", "dqn--ideal--seed4", "r-dqn--ideal--seed3"]
    rig_trial = spec.trials[-1]
    assert rig_trial.setting.name == "fast" and rig_trial.budget.max_episodes == 30
    run, params = run_spec_and_params(rig_trial)
    assert run.fidelity == "realistic" and params == RigParams.preset("mks-x5-hbl550")
    assert load_spec(tmp_path / "grid.toml").trials == spec.trials  # the same ids every time: resume finds them


def test_delay_settings_build_the_delayed_twins():
    spec = parse_spec({"learners": ["dqn+actions"], "delay_steps": [2], "delay_ms": [90], "seeds": 1})
    steps, ms = (run_spec_and_params(t)[0] for t in spec.trials)
    assert steps.fidelity == "ideal" and steps.delay_steps == 2
    assert ms.fidelity.network.observation_latency.floor_ms == 90


@pytest.mark.parametrize("record, message", [
    ({"learners": ["dqn"], "fidelities": ["ideal"], "seed": 2}, "unknown keys in the sweep spec: seed"),
    ({"learners": ["dqm"], "fidelities": ["ideal"]}, "unknown learner 'dqm'"),
    ({"learners": ["dqn"]}, "names no setting"),
    ({"learners": ["dqn"], "fidelities": ["perfect"]}, "fidelities: unknown 'perfect'"),
    ({"learners": ["dqn"], "delay_steps": [-1]}, "delay_steps: whole steps >= 0"),
    ({"learners": ["dqn"], "rigs": ["missing.json"]}, "rigs: no parameter file"),
    ({"learners": ["dqn"], "fidelities": ["ideal"], "seeds": [0, "1"]}, "seeds: a count"),
    ({"learners": ["dqn"], "fidelities": ["ideal"], "budget": {"max_episodes": 0}},
     "max_episodes and check_every whole numbers >= 1"),
    ({"learners": ["dqn"], "fidelities": ["ideal"], "budget": {"episodes": 9}}, "budget:"),
    ({"learners": ["dqn", "dqn"], "fidelities": ["ideal"]}, "the same trial twice"),
])
def test_a_wrong_spec_is_named_before_anything_runs(record, message, tmp_path):
    with pytest.raises(ConfigError, match=message):
        parse_spec(record, tmp_path)


def _row(learner, steps, seed, episodes):
    spec = parse_spec({"learners": [learner], "delay_steps": [steps], "seeds": [seed],
                       "budget": {"max_episodes": 300}})
    return {**spec.trials[0].to_dict(), "solved": episodes is not None, "episodes_to_solve": episodes,
            "wall_s_to_solve": None if episodes is None else 2.0 * episodes, "episodes": episodes or 300,
            "policy_solved": "9/10" if episodes else "2/10", "held_out_solved": episodes is not None,
            "wall_s": 600.0, "host": "h", "node_id": "n"}


def test_a_delay_sweep_becomes_lab_08s_file_and_the_benchmarks_lines(tmp_path):
    from pendkit.agents.results import delay_sweep

    rows = [_row("dqn", 0, 0, 50), _row("dqn", 0, 1, 70), _row("dqn", 2, 0, None), _row("dqn", 2, 1, None),
            _row("r-dqn", 0, 0, 90), _row("r-dqn", 0, 1, None), _row("r-dqn", 2, 0, 150), _row("r-dqn", 2, 1, 200)]
    path = tmp_path / "sweep.json"
    path.write_text(json.dumps(delay_sweep_record(rows, "pendkit sweep x.yaml --out d")))
    sweep = delay_sweep(path)
    assert sweep.delays_ms == [0.0, 120.0] and sweep.seeds == 2
    assert sweep.success_rate == {"dqn": [1.0, 0.0], "r-dqn": [0.5, 1.0]}
    lines = summary_lines(rows, ["r-dqn--ideal-delayed-4-steps--seed0"])
    assert ("algo=r-dqn fidelity=ideal-delayed-2-steps solved=2/2 median_episodes_to_policy=175 "
            "median_wall_s_to_policy=350 held_out=2/2 policy_solved=18/20") in lines
    assert ("algo=dqn fidelity=ideal-delayed-2-steps solved=0/2 median_episodes_to_policy=nan "
            "median_wall_s_to_policy=nan held_out=0/2 policy_solved=4/20") in lines
    assert "summary algo=dqn ideal-delayed-0-steps=2/2 ideal-delayed-2-steps=0/2" in lines
    assert "sweep algo=dqn success_rate: 0ms=1.00 120ms=0.00 largest_delay_solved_ms=0" in lines
    assert "sweep algo=r-dqn success_rate: 0ms=0.50 120ms=1.00 largest_delay_solved_ms=120" in lines
    assert lines[-1].startswith("sweep trials=9 finished=8 unfinished=1")


def _finished_folder(folder, seeds, solved_at):
    """A sweep folder as a run leaves it (spec.json, one result.json per trial), written without Ray."""
    from pendkit.sweep.ray_runner import prepare_folder
    from pendkit.sweep.spec import Budget, Setting, SweepSpec, Trial

    trials = tuple(Trial("dqn", Setting("fidelities", "ideal"), seed, Budget(max_episodes=100)) for seed in seeds)
    prepare_folder(SweepSpec("class", trials, {}), folder, resume=False)
    for trial, episodes in zip(trials, solved_at):
        (folder / "trials" / trial.trial_id).mkdir(parents=True)
        row = {**trial.to_dict(), "solved": episodes is not None, "episodes_to_solve": episodes,
               "wall_s_to_solve": episodes and episodes * 0.7, "episodes": episodes or 100, "wall_s": 70.0,
               "policy_solved": "10/10" if episodes else "0/10", "held_out_solved": episodes is not None,
               "host": "laptop", "node_id": None, "curve": f"trials/{trial.trial_id}/curve.csv"}
        (folder / "trials" / trial.trial_id / "result.json").write_text(json.dumps(row))


def test_a_class_gathers_each_students_seeds_into_one_table(tmp_path):
    from pendkit.sweep.report import report

    _finished_folder(tmp_path / "ana", [0], [50])
    _finished_folder(tmp_path / "ben", [1], [None])
    _finished_folder(tmp_path / "chloe", [2, 3], [70, 40])
    lines = []
    rows = report(tmp_path / "ana", say=lines.append, figure=False, more=[tmp_path / "ben", tmp_path / "chloe"])
    assert [r["seed"] for r in rows] == [0, 1, 2, 3]
    assert ("algo=dqn fidelity=ideal solved=3/4 median_episodes_to_policy=50 median_wall_s_to_policy=35 "
            "held_out=3/4 policy_solved=30/40") in lines
    table = (tmp_path / "ana" / "table.csv").read_text().splitlines()
    assert len(table) == 5 and str(tmp_path / "ben") in table[2]
    report(tmp_path / "class", say=lines.append, figure=False, more=[tmp_path / "ben", tmp_path / "chloe"])
    assert len((tmp_path / "class" / "table.csv").read_text().splitlines()) == 1 + 3  # a folder for the table


def test_a_sweep_folder_is_never_overwritten_nor_resumed_with_another_spec(tmp_path):
    from pendkit.sweep.ray_runner import prepare_folder

    _finished_folder(tmp_path / "run", [0, 1], [50, None])
    other = parse_spec({"learners": ["dqn"], "fidelities": ["ideal"], "seeds": [0, 1]})  # another budget
    with pytest.raises(ConfigError, match="--resume"):
        prepare_folder(other, tmp_path / "run", resume=False)
    with pytest.raises(ConfigError, match="another sweep"):
        prepare_folder(other, tmp_path / "run", resume=True)


def test_seeds_from_the_command_line_replace_the_specs(tmp_path):
    (tmp_path / "s.yaml").write_text("learners: [dqn]\nfidelities: [ideal]\nseeds: 3\n")
    assert [t.seed for t in load_spec(tmp_path / "s.yaml", [7]).trials] == [7]
    assert [t.seed for t in load_spec(tmp_path / "s.yaml").trials] == [0, 1, 2]


def test_every_spec_the_kit_ships_parses():
    from pathlib import Path

    specs = sorted((Path(__file__).resolve().parents[2] / "benchmarks" / "sweeps").glob("*.yaml"))
    assert {p.stem for p in specs} >= {"smoke", "lab08-delay", "paper-grid", "delay-full", "delay-ms", "cost"}
    for path in specs:
        assert load_spec(path).trials, path
