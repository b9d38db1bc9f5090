"""`pendkit grade` writes no grade through a link planted in its --out folder, and says so before any
notebook runs (issue 72, part 4)."""

import os
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.grading.report import write_reports
from pendkit.grading.runner import SubmissionGrade
from pendkit.safe_write import LinkRefused

ROOT = Path(__file__).resolve().parents[2]
NOTES = "the instructor's notes\n"
pytestmark = pytest.mark.skipif(os.name == "nt", reason="symbolic links (POSIX)")


@pytest.fixture
def planted(tmp_path):
    """A class of one (alice), an empty --out folder, and the instructor's file outside both."""
    (tmp_path / "class" / "alice").mkdir(parents=True)
    shutil.copy(ROOT / "labs" / "01_encoder.ipynb", tmp_path / "class" / "alice")
    (tmp_path / "grades").mkdir()
    notes = tmp_path / "notes.txt"
    notes.write_text(NOTES)
    return tmp_path / "class", tmp_path / "grades", notes


def grade(folder, out):
    return CliRunner().invoke(main, ["grade", str(folder), "--out", str(out), "--public-only", "--lab", "01",
                                     "--no-sandbox", "--quiet"])


@pytest.mark.parametrize("where", ["grades.csv", "alice/results.json", "alice"])
def test_a_link_where_a_grade_goes_is_refused_before_any_notebook_runs(planted, where):
    folder, out, notes = planted
    if where == "alice/results.json":
        (out / "alice").mkdir()
    (out / where).symlink_to(notes if where != "alice" else notes.parent)
    result = grade(folder, out)
    assert result.exit_code == 1, result.output
    assert f"refused to write {out / where}" in result.output or f"{out / where} is a symbolic link" in result.output
    assert notes.read_text() == NOTES and "Traceback" not in result.output
    assert not (notes.parent / "results.json").exists()


def test_the_reports_writer_itself_refuses_a_link(planted):
    _, out, notes = planted
    (out / "grades.csv").symlink_to(notes)
    with pytest.raises(LinkRefused, match="grades.csv"):
        write_reports([SubmissionGrade("alice", "alice/01_encoder.ipynb", "01")], out)
    assert notes.read_text() == NOTES
    assert (out / "alice" / "results.json").exists()  # what it could write is written
