"""`pendkit sweep report` writes nothing through a link planted in the sweep's folder (issue 72, part 4)."""

import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.safe_write import LinkRefused
from pendkit.sweep.report import write_table
from tests.sweep.test_spec import _finished_folder

NOTES = "the instructor's notes\n"


@pytest.fixture
def planted(tmp_path):
    """A finished sweep folder, and the instructor's file outside it."""
    _finished_folder(tmp_path / "student", [0], [50])
    notes = tmp_path / "notes.txt"
    notes.write_text(NOTES)
    return tmp_path / "student", notes


@pytest.mark.parametrize("name", ["table.csv", "table.json", "summary.png"])
def test_a_link_where_the_report_writes_is_refused_by_name(planted, name):
    folder, notes = planted
    (folder / name).symlink_to(notes)
    result = CliRunner().invoke(main, ["sweep", "report", str(folder)])
    assert result.exit_code == 1 and f"refused to write {folder / name}: it is a symbolic link" in result.output
    assert notes.read_text() == NOTES and "Traceback" not in result.output


def test_a_link_at_the_delay_sweep_file_is_refused_by_name(planted, tmp_path):
    folder, notes = planted
    (tmp_path / "sweep.json").symlink_to(notes)
    result = CliRunner().invoke(main, ["sweep", "report", str(folder), "--no-figure",
                                       "--delay-sweep-json", str(tmp_path / "sweep.json")])
    assert result.exit_code == 1 and f"refused to write {tmp_path / 'sweep.json'}" in result.output
    assert notes.read_text() == NOTES


def test_the_tables_writer_itself_refuses_a_link(planted):
    folder, notes = planted
    (folder / "table.json").symlink_to(notes)
    with pytest.raises(LinkRefused, match="table.json"):
        write_table(folder, [])
    assert notes.read_text() == NOTES
