"""`pendkit broker` and `pendkit virtual-rig` as processes, the way a student runs them, and the env on top."""

import contextlib
import signal
import subprocess
import sys
import time

from click.testing import CliRunner

import pendkit
from pendkit.cli import main
from pendkit.link.broker import free_port, wait_for_port


@contextlib.contextmanager
def broker_and_rig(*rig_args):
    """`pendkit broker` on a free port and `pendkit virtual-rig --broker URL RIG_ARGS...` as processes; yields
    (url, broker, rig), then stops both with Ctrl-C."""
    port = free_port()
    url = f"mqtt://127.0.0.1:{port}"
    broker = subprocess.Popen([sys.executable, "-m", "pendkit.cli", "broker", "--port", str(port)],
                              stdout=subprocess.PIPE, text=True)
    rig = None
    try:
        assert wait_for_port("127.0.0.1", port, 15)
        rig = subprocess.Popen([sys.executable, "-m", "pendkit.cli", "virtual-rig", "--broker", url, *rig_args],
                               stdout=subprocess.PIPE, text=True)
        yield url, broker, rig
    finally:
        for process in (rig, broker):
            if process is not None:
                process.send_signal(signal.SIGINT)
                process.wait(timeout=10)


def test_broker_and_virtual_rig_commands_serve_the_env():
    with broker_and_rig("--rig", "r07", "--speed", "2") as (url, broker, rig):
        time.sleep(2.0)
        env = pendkit.make(backend="rig", rig="r07", broker=url, rig_options={"reset_stop_s": 0.2})
        observation, _ = env.reset(seed=0)
        for _ in range(10):
            observation, *_ = env.step(3)
        assert observation[1] > 0.05  # the arm moved right
        env.close()
    assert broker.returncode == 0 and rig.returncode == 0  # Ctrl-C stops both cleanly


def test_broker_config_command(tmp_path):
    result = CliRunner().invoke(main, ["broker-config", "--rigs", "r01", "--rigs", "r02", "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    acl = (tmp_path / "acl").read_text()
    assert "user host-r02\ntopic write pendulum-r/act/r02" in acl
    assert "allow_anonymous false" in (tmp_path / "mosquitto.conf").read_text()
    assert "set_tcp_nodelay true" in (tmp_path / "mosquitto.conf").read_text()
    bad = CliRunner().invoke(main, ["broker-config", "--rigs", "r01", "--rigs", "r01", "--out", str(tmp_path)])
    assert bad.exit_code == 2 and "distinct" in bad.output


def test_virtual_rig_serves_the_rig_a_parameter_file_describes(tmp_path):
    """`pendkit virtual-rig --params RIG.json` (RigParams.save's format) serves that rig, not the default:
    its status reports the file's servo end counts, which is all a rig's firmware says of itself."""
    import dataclasses

    from pendkit.adapt.rigs import rig_status
    from pendkit.rig import RigParams

    narrow = dataclasses.replace(RigParams().with_dowel_length(0.33), servo_min_counts=183, servo_max_counts=417)
    narrow.save(tmp_path / "rig.json")
    with broker_and_rig("--rig", "r08", "--params", str(tmp_path / "rig.json")) as (url, _, _):
        status = {}
        for _ in range(20):  # the rig process starts MuJoCo first
            status = rig_status("r08", url, wait_s=1.0)
            if status:
                break
    assert status.get("servo_counts_range") == [183, 417]
    assert RigParams().servo_min_counts != 183  # the default would not say so
