"""`pendkit adapt` writes nothing through a link planted in its --out folder: refused before any rig time
is spent, and by each of its writers (rig.json, policy.pt, blobs, recordings) (issue 72, part 4)."""

import os

import pytest
from click.testing import CliRunner

from pendkit.adapt.session import OUTPUTS, save_device_design
from pendkit.adapt.trials import Design
from pendkit.agents.data_files import save_data
from pendkit.cli import main
from pendkit.rig import RigParams
from pendkit.safe_write import LinkRefused
from pendkit.telemetry.log import EpisodeLog

NOTES = "the instructor's notes\n"
pytestmark = pytest.mark.skipif(os.name == "nt", reason="symbolic links (POSIX)")


@pytest.fixture
def planted(tmp_path):
    notes = tmp_path / "notes.txt"
    notes.write_text(NOTES)
    (tmp_path / "out").mkdir()
    RigParams().save(tmp_path / "rig.json")
    return tmp_path / "out", notes


@pytest.mark.parametrize("name", ["report.md", "rig.json", "policy.pt", "excitation-logs"])
def test_a_link_where_adapt_writes_is_refused_before_the_rig_is_used(planted, name):
    out, notes = planted
    assert name in OUTPUTS
    (out / name).symlink_to(notes)
    result = CliRunner().invoke(main, ["adapt", "--backend", "sim", "--params", str(out.parent / "rig.json"),
                                       "--out", str(out), "--impairment", "none"])
    assert result.exit_code == 1 and f"refused to write {out / name}: it is a symbolic link" in result.output
    assert notes.read_text() == NOTES and "excitation episodes" not in result.output


@pytest.mark.parametrize("writer", [
    lambda path: RigParams().save(path),  # rig.json, device-design-rig.json
    lambda path: save_data(path, {"agent": {}}),  # policy.pt (save_weights)
    lambda path: EpisodeLog(path),  # the excitation recordings
    lambda path: save_device_design(Design("x", "energy", RigParams(), b"PKCB"), path.parent, {}),
], ids=["rig-json", "weights", "recording", "device-design"])
def test_each_writer_adapt_uses_refuses_a_link(planted, writer):
    out, notes = planted
    for name in ("target", "device-design-rig.json"):
        (out / name).symlink_to(notes)
    with pytest.raises(LinkRefused, match="is a symbolic link"):
        writer(out / "target")
    assert notes.read_text() == NOTES
