"""Crafted run folders end `pendkit eval`, `export` and `deploy` in one line naming what is wrong, before
anything is built or run (issue 72 part 6): no traceback, no endless episode, no 160 GB network."""

import json

import pytest
from click.testing import CliRunner

from pendkit.agents.data_files import load_data, save_data
from pendkit.agents.runs import RunSpec, build_run, save_weights
from pendkit.cli import main
from pendkit.errors import ConfigError

pytest.importorskip("torch")
COMMANDS = {"eval": ["--episodes", "1", "--start", "rest"], "export": ["--out", "{tmp}/out.pkcb"],
            "deploy": ["--rig", "r01", "--broker", "mqtt://127.0.0.1:1"]}


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """A real run's weights file (an R-DQN, untrained), as data."""
    spec = RunSpec("r-dqn", "ideal", max_steps=10)
    env, agent, _ = build_run(spec)
    env.close()
    path = save_weights(tmp_path_factory.mktemp("run") / "final.pt", agent, spec)
    return load_data(path)


def weights(folder, record, spec_changes=None, state=None, raw_spec=None):
    changed = {**record, "spec": raw_spec if raw_spec is not None else {**record["spec"], **(spec_changes or {})}}
    save_data(folder / "final.pt", changed if state is None else {**changed, "agent": state})


def checkpoint(folder, record, config_text):
    save_data(folder / "checkpoint.pt", {"agent": record["agent"], "episode": 1})
    if config_text is not None:
        (folder / "config.json").write_text(config_text)


def with_nan(record):
    state = load_data_copy(record)["agent"]
    name = next(k for k in state["q"] if k.endswith("weight"))
    state["q"][name] = state["q"][name].clone()
    state["q"][name][0, 0] = float("nan")
    return state


def load_data_copy(record):
    import copy

    return copy.deepcopy(record)


CASES = {  # name: (how the folder is crafted, what the one line says)
    "max_steps of 10**9": (lambda f, r: weights(f, r, {"max_steps": 10**9}), "max_steps = 1000000000 is not a whole "
                           "number in 1..5000"),
    "200000-unit layers": (lambda f, r: weights(f, r, {"agent": {"hidden": [200000, 200000]}}),
                           "agent: hidden = [200000, 200000] is not a list of 1..8 layer widths in 1..1024"),
    "no config.json beside a checkpoint": (lambda f, r: checkpoint(f, r, None), "nor a checkpoint beside its "
                                           "config.json"),
    "config.json not JSON": (lambda f, r: checkpoint(f, r, "{not json"), "its run spec is not one the kit can build"),
    "config.json not an object": (lambda f, r: checkpoint(f, r, "[1, 2]"), "a run spec is an object of named "
                                  "fields, got list"),
    "a spec not an object": (lambda f, r: weights(f, r, raw_spec=[1, 2]), "a run spec is an object of named fields"),
    "unknown algo": (lambda f, r: checkpoint(f, r, json.dumps({"algo": "nope"})), "unknown learner 'nope'"),
    "a string for the seed": (lambda f, r: weights(f, r, {"seed": "zero"}), "seed = 'zero' is not a whole number"),
    "a string for hidden": (lambda f, r: weights(f, r, {"agent": {"hidden": "64"}}), "agent: hidden = '64' is not"),
    "a string for a rate": (lambda f, r: weights(f, r, {"agent": {"learning_rate": "fast"}}),
                            "agent: learning_rate = 'fast' is not a finite number"),
    "a negative seed": (lambda f, r: weights(f, r, {"seed": -3}), "seed = -3 is not a whole number in 0..4294967295"),
    "a negative layer": (lambda f, r: weights(f, r, {"agent": {"hidden": [-1, 64]}}), "agent: hidden = [-1, 64]"),
    "a negative buffer": (lambda f, r: weights(f, r, {"agent": {"buffer_capacity": -1}}),
                          "agent: buffer_capacity = -1 is not a whole number in 1..10000000"),
    "no final.pt": (lambda f, r: None, "no weights in"),
    "final.pt not a torch file": (lambda f, r: (f / "final.pt").write_text("hello"), "is not a readable weights "
                                  "file"),
    "weights of another shape": (lambda f, r: weights(f, r, {"agent": {"hidden": [32, 32]}}),
                                 "its weights do not fit the agent its spec builds (size mismatch"),
    "NaN in the weights": (lambda f, r: weights(f, r, state=with_nan(r)), "q.head.0.weight holds NaN or infinity"),
}


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("case", CASES)
def test_a_crafted_run_folder_is_one_line(tmp_path, record, case, command):
    folder = tmp_path / "run"
    folder.mkdir()
    craft, says = CASES[case]
    craft(folder, record)
    extra = [part.format(tmp=tmp_path) for part in COMMANDS[command]]
    result = CliRunner().invoke(main, [command, str(folder), *extra])
    assert result.exit_code == 1, result.output
    assert says in result.output and "Traceback" not in result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.output
    assert not (tmp_path / "out.pkcb").exists()


@pytest.mark.parametrize("changes, says", [
    ({"delay_steps": 51}, "delay_steps = 51 is not a whole number in 0..50"),
    ({"preset": "nope"}, "preset = 'nope' is not one of"),
    ({"fidelity": ["ideal"]}, "fidelity = ['ideal'] is not one of"),
    ({"randomize": 3}, "randomize = 3 is not text"),
    ({"agent": {"gru_size": 10**6}}, "agent: gru_size = 1000000 is not a whole number in 1..512"),
    ({"agent": {"gamma": float("nan")}}, "agent: gamma = nan is not a finite number"),
])
def test_each_field_of_a_run_spec_is_bounded_by_name(changes, says):
    with pytest.raises(ConfigError, match=says.replace("[", r"\[").replace("]", r"\]")):
        RunSpec.from_dict({**RunSpec("r-dqn").to_dict(), **changes})


def test_the_kits_own_specs_are_inside_the_bounds():
    from pendkit.agents.pretrained import POLICIES

    for spec in POLICIES.values():
        assert RunSpec.from_dict(spec.run.to_dict()) == spec.run
