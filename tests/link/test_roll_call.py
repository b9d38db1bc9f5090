"""`pendkit rigs`: the room's roll call names the rigs online, the ones that went offline and the ones
expected that never reported, and fails unless all are online."""

from click.testing import CliRunner

from pendkit.cli import main
from pendkit.link.broker import EmbeddedBroker, free_port
from pendkit.link.virtual_rig import VirtualRig, VirtualRigGroup


def test_the_roll_call_tells_online_offline_and_never_seen_apart():
    with EmbeddedBroker(port=free_port()) as broker:
        gone = VirtualRigGroup([VirtualRig("r02", broker.url)]).start()
        gone.stop()  # its retained status now says offline
        with VirtualRigGroup([VirtualRig("r01", broker.url)]):
            partial = CliRunner().invoke(main, ["rigs", "--broker", broker.url, "--expect", "r01", "--expect", "r03"])
            alone = CliRunner().invoke(main, ["rigs", "--broker", broker.url, "--expect", "r01"])
    lines = partial.output.splitlines()
    assert partial.exit_code == 1, partial.output
    assert lines[0].startswith("r01") and "online, protocol 2, servo counts 150..450" in lines[0]
    assert lines[1].startswith("r02") and "offline" in lines[1]
    assert lines[2].startswith("r03") and "never reported" in lines[2]
    assert lines[-1].startswith("1 of 3 rigs online")
    assert alone.exit_code == 1 and "1 of 2 rigs online" in alone.output  # r02 is still known, and offline
