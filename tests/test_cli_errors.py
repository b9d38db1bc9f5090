"""Every `pendkit` subcommand, given bad arguments, ends with one line naming the fix: never a traceback.
A new subcommand must add its bad case here (the first test says so)."""

import numpy as np
import pytest
from click.testing import CliRunner

import pendkit
from pendkit.cli import main

BAD = {
    "adapt": ["adapt", "--backend", "sim", "--out", "o", "--params", "not-a-file.json"],
    "autograder-run": ["autograder-run", "--root", "no-such-folder", "--lab", "42"],
    "bom": ["bom", "no-such.csv"],
    "broker": ["broker", "--port", "99999"],
    "broker-config": ["broker-config", "--rigs", "+", "--out", "bc"],
    "cad": ["cad", "--preset", "no-such-servo"],
    "demo": ["demo", "--seed", "x"],
    "deploy": ["deploy", "--rig", "+", "--controller", "energy"],
    "eval": ["eval", "not-a-run"],
    "export": ["export", "not-a-run", "--out", "x.pkcb"],
    "firmware-header": ["firmware-header", "--preset", "no-such-servo"],
    "grade": ["grade", "class", "--lab", "42"],
    "info": ["info", "--preset", "no-such-servo"],
    "labs": ["labs", "build", "--solutions", "not-a-run"],
    "plot": ["plot", "not-a-run"],
    "policies": ["policies", "build", "no-such-policy"],
    "queue": ["queue", "submit", "--controller", "energy", "--excitation"],
    "rigs": ["rigs", "--broker", "mqtt://127.0.0.1:0"],
    "sweep": ["sweep", "no-such-spec.yaml", "--out", "s"],
    "train": ["train", "--episodes", "0"],
    "virtual-rig": ["virtual-rig", "--rig", "+"],
    "wiring": ["wiring", "--pins", "no-such-pins.h"],
}
MORE_BAD = [
    (["grade", "class", "--cell-timeout", "nan"], "positive number of seconds"),
    (["grade", "class", "--cell-timeout", "inf"], "positive number of seconds"),
    (["grade", "class", "--check-timeout", "-5"], "positive number of seconds"),
    (["grade", "--gradescope-autograder", "x.zip", "--lab", "42"], "no lab '42'"),
    (["grade", "class", "--hidden", "/nonexistent"], "holds no hidden tests"),
    (["eval", "not-a-run"], "no weights"),
    (["plot", "not-a-run"], "not a training run"),
    (["export", "--policy", "dqn-ideal", "--out", "x.pkcb"], "the device runs r-dqn and r-td3+both policies"),
    (["virtual-rig", "--rig", "+"], "not a rig's name"),
    (["deploy", "--rig", "+", "--controller", "energy"], "not a rig's name"),
    (["export", "--controller", "energy", "--policy", "r-dqn-realistic", "--out", "x.pkcb"], "give one of"),
    (["deploy", "--rig", "r01", "--blob", "not-a-run"], "is a directory"),
    (["broker", "--port", "99999"], "65535"),
    (["rigs", "--broker", "mqtt://127.0.0.1:0"], "broker must look like"),
    (["eval", "--controller", "energy", "--preset", "hitec-d645mw", "--params", "not-a-run"], "is a directory"),
    (["sweep", "no-such-spec.yaml", "--out", "s"], "no sweep spec at"),
    (["sweep", "report", "not-a-run"], "not a sweep folder"),
    (["adapt", "--backend", "sim", "--out", "o", "--loop-episodes", "-1"], "not in the range"),
    (["adapt", "--backend", "sim", "--out", "o", "--candidate", "r-td3-bank-robst"], "not a shipped policy"),
    (["queue", "serve", "--tls-cert", "not-a-run"], "is a directory"),
    (["queue", "serve", "--db", "nosuchdialect://x"], "queue database"),
    (["queue", "submit", "--controller", "energy", "--blob", "x.pkcb"], "does not exist"),
    (["queue", "submit", "--policy", "r-dqn-realistic", "--controller", "energy"], "give one of"),
    (["queue", "submit", "--excitation", "--token", "a-secret"], "visible to every user"),
    (["queue", "submit", "--excitation", "--server", "ftp://10.0.0.5"], "http://HOST:PORT"),
    (["queue", "status", "--server", "http://127.0.0.1:1"], "no team token"),
    (["queue", "result", "x", "--out", "o"], "not a valid integer"),
    (["queue", "cancel", "0"], "x>=1"),
    (["queue", "teams", "--credentials", "not-a-run"], "is a directory"),
    (["queue", "rigs", "--db", "queue.db", "--put-back", "r99"], "no rig 'r99'"),
    (["queue", "run", "--speed", "0"], "0.1<=x<=100"),
]


def run(args, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "not-a-run").mkdir()
    (tmp_path / "class").mkdir()
    return CliRunner().invoke(main, args)


def test_every_subcommand_has_a_bad_case():
    assert set(main.commands) == set(BAD)


def assert_one_line_error(result):
    assert result.exit_code not in (0, None), result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(result.exception)
    assert "Traceback" not in result.output
    assert result.output.strip().splitlines()[-1].startswith("Error: "), result.output


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_arguments_end_in_one_line_not_a_traceback(name, tmp_path, monkeypatch):
    assert_one_line_error(run(BAD[name], tmp_path, monkeypatch))


@pytest.mark.parametrize(("args", "says"), MORE_BAD, ids=[" ".join(a) for a, _ in MORE_BAD])
def test_bad_options_name_what_is_wrong(args, says, tmp_path, monkeypatch):
    result = run(args, tmp_path, monkeypatch)
    assert_one_line_error(result)
    assert says in result.output


def test_a_taken_port_is_named_as_such():
    from pendkit.link.broker import EmbeddedBroker

    with EmbeddedBroker(port=18839) as first:
        result = CliRunner().invoke(main, ["broker", "--port", str(first.port)])
    assert_one_line_error(result)
    assert "another broker" in result.output


def test_a_broker_that_is_not_there_is_one_line():
    result = CliRunner().invoke(main, ["eval", "--policy", "dqn-ideal", "--backend", "rig",
                                       "--broker", "mqtt://127.0.0.1:1", "--episodes", "1"])
    assert_one_line_error(result)
    assert "pendkit broker" in result.output


def test_make_takes_numpy_integers_and_names_what_it_cannot_do():
    assert pendkit.make(max_episode_steps=np.int64(10)).spec.max_episode_steps == 10
    with pytest.raises(pendkit.ConfigError, match="rgb_array"):
        pendkit.make(render_mode="human")
    with pytest.raises(pendkit.ConfigError, match="at least one feature"):
        pendkit.make(observation=())
