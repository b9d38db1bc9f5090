"""A sweep stays in its folder, refuses what it cannot run before anything runs, and reports what it can."""

import json

import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.errors import ConfigError
from pendkit.sweep.ray_runner import prepare_folder
from pendkit.sweep.report import report
from pendkit.sweep.spec import load_spec, parse_spec
from tests.sweep.test_spec import _finished_folder

BASE = {"learners": ["dqn"], "fidelities": ["ideal"]}


@pytest.mark.parametrize("record, message", [
    ({**BASE, "name": "../../escaped"}, "name: letters, digits"),
    ({**BASE, "name": "/abs"}, "name: letters"),
    ({**BASE, "seeds": 1_000_000}, "seeds: a count in"),
    ({**BASE, "seeds": [2**64]}, "seeds: a count >= 1 or a list of integers in"),
    ({"learners": ["dqn", "td3", "r-dqn"], "delay_steps": list(range(40)), "seeds": 100}, "expands to 12000"),
    ({**BASE, "agent": {"learnin_rate": 0.1}}, "learnin_rate is not a setting of dqn"),
    ({**BASE, "agent": {"learning_rate": "fast"}}, "agent:"),
    ({**BASE, "budget": {"max_episodes": "10"}}, "budget: max_episodes"),
    ({**BASE, "budget": {"max_wall_s": float("nan")}}, "budget:"),
    ({"learners": ["dqn"], "fidelities": [["ideal"]]}, "fidelities: unknown"),
    ({**BASE, "randomize": 3}, "randomize:"),
])
def test_a_spec_out_of_range_or_of_the_wrong_type_is_refused_by_name(record, message):
    with pytest.raises(ConfigError, match=message):
        parse_spec(record)


def test_a_params_file_that_is_not_a_rig_is_refused(tmp_path):
    (tmp_path / "rig.json").write_text(json.dumps({"servo_speed": "fast"}))
    with pytest.raises(ConfigError, match="is not a rig's parameter file"):
        parse_spec({"learners": ["dqn"], "rigs": ["rig.json"]}, tmp_path)


@pytest.mark.parametrize("suffix, text, where", [
    (".yaml", "learners: [dqn\nfidelities: [ideal]\n", ".yaml:2:"),
    (".yaml", "learners: !!python/object/apply:os.system ['touch pwned']\n", ".yaml:1:"),
    (".toml", "learners = [dqn]\n", "not valid TOML"),
    (".json", '{"learners": ["dqn"],}', ".json:1:"),
])
def test_a_broken_spec_file_is_one_line_with_where(tmp_path, suffix, text, where):
    path = tmp_path / f"spec{suffix}"
    path.write_text(text)
    with pytest.raises(ConfigError, match=where.replace(".", r"\.")):
        load_spec(path)
    result = CliRunner().invoke(main, ["sweep", "run", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code != 0 and "Traceback" not in result.output and len(result.output.splitlines()) <= 2
    assert not (tmp_path / "pwned").exists()


def test_an_existing_folder_that_holds_no_sweep_is_refused_and_left_alone(tmp_path):
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "table.csv").write_text("my own table")
    spec = parse_spec(BASE)
    with pytest.raises(ConfigError, match="holds files but no sweep"):
        prepare_folder(spec, tmp_path / "mine", resume=False)
    assert (tmp_path / "mine" / "table.csv").read_text() == "my own table"
    assert prepare_folder(spec, tmp_path / "new", resume=False)  # a new or empty folder is fine


@pytest.mark.parametrize("tamper", [
    lambda row: "not json", lambda row: json.dumps([1]), lambda row: json.dumps({**row, "solved": "yes"}),
    lambda row: json.dumps({**row, "episodes": "many"}), lambda row: json.dumps({**row, "seed": 99}),
    lambda row: json.dumps({**row, "budget": None}), lambda row: json.dumps({k: v for k, v in row.items()
                                                                             if k != "curve"}),
    lambda row: json.dumps({**row, "solved": True, "episodes_to_solve": None}),
])
def test_report_leaves_out_a_tampered_trial_with_its_reason_and_reports_the_rest(tmp_path, tamper):
    _finished_folder(tmp_path / "run", [0, 1], [50, 70])
    result = tmp_path / "run" / "trials" / "dqn--ideal--seed1" / "result.json"
    result.write_text(tamper(json.loads(result.read_text())))
    lines = []
    rows = report(tmp_path / "run", say=lines.append, figure=False)
    assert [r["seed"] for r in rows] == [0]
    assert any(line.startswith("skipped:") and "dqn--ideal--seed1" in line for line in lines)


def test_one_bad_folder_does_not_stop_a_class_report(tmp_path):
    _finished_folder(tmp_path / "ana", [0], [50])
    _finished_folder(tmp_path / "ben", [1], [60])
    (tmp_path / "ben" / "spec.json").write_text('{"trials": [{"trial_id": "../../../etc"}]}')
    _finished_folder(tmp_path / "cy", [2], [None])
    (tmp_path / "cy" / "spec.json").write_text("garbage")
    lines = []
    rows = report(tmp_path / "class", say=lines.append, figure=False,
                  more=[tmp_path / "ana", tmp_path / "ben", tmp_path / "cy"])
    assert [r["seed"] for r in rows] == [0]
    assert sum(line.startswith("skipped:") for line in lines) == 2
