"""Run as root, Mosquitto drops to its own user: broker-config says when that user could not enter the
folder it writes to (and so could not read the password file or the key)."""

import os

import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.link.secret_files import folder_closed_to_broker


def mosquitto_user_exists() -> bool:
    try:
        import grp

        grp.getgrnam("mosquitto")
        return True
    except (ImportError, KeyError):
        return False


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0 or not mosquitto_user_exists(),
                    reason="only as root with a mosquitto user does Mosquitto change user")
def test_a_private_folder_is_named_and_an_open_one_is_not(tmp_path):
    private = tmp_path / "private"
    private.mkdir(mode=0o700)
    tmp_path.chmod(0o755)
    assert folder_closed_to_broker(private / "broker") is not None  # pytest's own folders are private too
    result = CliRunner().invoke(main, ["broker-config", "--rigs", "r01", "--out", str(private / "broker")])
    assert result.exit_code == 0 and "warning: Mosquitto drops to its own user" in result.output, result.output


def test_nothing_is_said_where_mosquitto_runs_as_whoever_started_it(tmp_path, monkeypatch):
    monkeypatch.setattr(os, "geteuid", lambda: 1000)
    assert folder_closed_to_broker(tmp_path) is None
