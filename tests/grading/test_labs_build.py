"""`pendkit labs build` and `pendkit labs check`: one source, stubs, no instructor material in labs/."""

import json
import shutil
from pathlib import Path

import nbformat
import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.errors import ConfigError
from pendkit.labs.build import STUB, strip_solutions

ROOT = Path(__file__).resolve().parents[2]


def test_committed_labs_are_current():
    result = CliRunner().invoke(main, ["labs", "check", "--solutions", str(ROOT / "solutions"),
                                       "--labs", str(ROOT / "labs")])
    assert result.exit_code == 0, result.output


def test_student_copies_hold_no_solutions_or_instructor_material():
    for lab in sorted((ROOT / "labs").glob("*.ipynb")):
        text = lab.read_text()
        notebook = nbformat.read(lab, as_version=4)
        assert "BEGIN SOLUTION" not in text and "Instructor note" not in text
        assert "NBVAL_CHECK_OUTPUT" not in text
        assert all(not c.get("outputs") for c in notebook.cells if c.cell_type == "code")
        assert any(STUB in c.source for c in notebook.cells)
        assert notebook.metadata["pendkit"]["lab"] == lab.name[:2]
    assert not list((ROOT / "labs").glob("**/*hidden*"))


def test_stub_keeps_indentation_and_the_code_around_it():
    source = "def f(x):\n    y = 1\n    ### BEGIN SOLUTION\n    return x + y\n    ### END SOLUTION\nprint(2)"
    assert strip_solutions(source, "t") == f"def f(x):\n    y = 1\n    {STUB}\nprint(2)"
    with pytest.raises(ConfigError, match="never closed"):
        strip_solutions("### BEGIN SOLUTION\nx = 1", "t")
    with pytest.raises(ConfigError, match="without"):
        strip_solutions("### END SOLUTION", "t")


def test_check_fails_when_a_solution_changes_and_build_fixes_it(tmp_path):
    solutions, labs = tmp_path / "solutions", tmp_path / "labs"
    shutil.copytree(ROOT / "solutions", solutions, ignore=shutil.ignore_patterns("tests"))
    runner = CliRunner()
    assert runner.invoke(main, ["labs", "build", "--solutions", str(solutions), "--out", str(labs)]).exit_code == 0
    first = {p.name: p.read_text() for p in labs.glob("*.ipynb")}
    runner.invoke(main, ["labs", "build", "--solutions", str(solutions), "--out", str(labs)])
    assert first == {p.name: p.read_text() for p in labs.glob("*.ipynb")}  # deterministic
    notebook = json.loads((solutions / "00_tour.ipynb").read_text())
    notebook["cells"][0]["source"] = ["# Lab 00, revised\n"]
    (solutions / "00_tour.ipynb").write_text(json.dumps(notebook))
    stale = runner.invoke(main, ["labs", "check", "--solutions", str(solutions), "--labs", str(labs)])
    assert stale.exit_code == 1 and "00_tour.ipynb is out of date" in stale.output
    (labs / "99_orphan.ipynb").write_text("{}")
    stale = runner.invoke(main, ["labs", "check", "--solutions", str(solutions), "--labs", str(labs)])
    assert "99_orphan.ipynb has no solution notebook" in stale.output
