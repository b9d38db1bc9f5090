"""No command takes a password on its command line (every user of the machine can read it with `ps`): it
comes from PENDKIT_MQTT_PASSWORD or a file, and reaches the broker either way."""

import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.link.broker import MosquittoBroker
from tests.system_needs import needs

RIG_COMMANDS = [["eval", "--policy", "dqn-ideal", "--backend", "rig"], ["deploy", "--controller", "energy"],
                ["train", "--backend", "rig"], ["adapt", "--out", "unused"], ["virtual-rig"], ["rigs"]]


def every_command_with_a_password_option():
    """The kit's commands that take a password at all: each must be in RIG_COMMANDS (a new one is tested)."""
    return sorted(name for name, command in main.commands.items()
                  if any(getattr(p, "name", None) == "password" for p in command.params))


def test_every_command_with_a_password_is_covered():
    assert every_command_with_a_password_option() == sorted(c[0] for c in RIG_COMMANDS)


@pytest.mark.parametrize("command", RIG_COMMANDS, ids=lambda c: c[0])
def test_a_password_on_the_command_line_is_refused_before_anything_runs(command):
    rig = [] if command[0] == "rigs" else ["--rig", "r01"]
    result = CliRunner().invoke(main, [*command, *rig, "--username", "r01", "--password", "s3cret"])
    assert result.exit_code == 2, result.output
    assert "visible to every user of this machine" in result.output and "PENDKIT_MQTT_PASSWORD" in result.output


@needs("mosquitto")
def test_the_password_from_a_file_or_the_environment_reaches_the_broker(tmp_path):
    secret = tmp_path / "password"
    with MosquittoBroker(tmp_path / "room", rigs=["r01"]) as broker:
        right = broker.credentials()["host-r01"]
        for password, expected in ((right, "rig r01 did not answer"), ("wrong", "username or password is wrong")):
            secret.write_text(password + "\n")
            for extra, env in ((["--password-file", str(secret)], {}), ([], {"PENDKIT_MQTT_PASSWORD": password})):
                result = CliRunner().invoke(main, ["eval", "--policy", "dqn-ideal", "--backend", "rig", "--broker",
                                                   broker.url, "--rig", "r01", "--username", "host-r01", *extra],
                                            env=env)
                assert result.exit_code == 1 and expected in result.output, (extra, result.output)
    both = CliRunner().invoke(main, ["eval", "--policy", "dqn-ideal", "--backend", "rig", "--username", "u",
                                     "--password-file", str(secret)], env={"PENDKIT_MQTT_PASSWORD": "x"})
    assert both.exit_code == 2 and "not both" in both.output
    secret.write_text("")
    empty = CliRunner().invoke(main, ["eval", "--policy", "dqn-ideal", "--password-file", str(secret)])
    assert empty.exit_code == 2 and "is empty" in empty.output
