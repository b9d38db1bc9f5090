"""Gradescope's autograder zip, run in a scratch folder laid out like /autograder."""

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import nbformat
import pytest
from click.testing import CliRunner

from pendkit.cli import main
from pendkit.grading.gradescope import unpack_for_test

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.expensive  # the full tier: a Gradescope run
def test_the_autograder_zip_grades_a_submission_like_gradescope(tmp_path):
    archive = tmp_path / "autograder.zip"
    result = CliRunner().invoke(main, ["grade", "--gradescope-autograder", str(archive), "--lab", "00",
                                       "--hidden", str(ROOT / "solutions" / "tests")])
    assert result.exit_code == 0, result.output
    names = zipfile.ZipFile(archive).namelist()
    assert {"setup.sh", "run_autograder", "hidden/lab00_hidden.py", "pendkit-src/pyproject.toml"} <= set(names)
    assert not any(name.startswith("hidden/lab01") for name in names)
    setup = zipfile.ZipFile(archive).read("setup.sh").decode()
    assert "torch==2.13.0" in setup and "download.pytorch.org/whl/cpu" in setup and "bubblewrap" in setup

    root = unpack_for_test(archive, tmp_path / "autograder")
    scores = {}
    notebooks = {"solution": ROOT / "solutions" / "00_tour.ipynb", "template": ROOT / "labs" / "00_tour.ipynb"}
    for name, notebook in notebooks.items():
        for old in (root / "submission").iterdir():
            old.unlink()
        nbformat.write(nbformat.read(notebook, as_version=4), root / "submission" / "00_tour.ipynb")
        env = {**os.environ, "AUTOGRADER_ROOT": str(root), "AUTOGRADER_PYTHON": sys.executable}
        subprocess.run(["bash", str(root / "source" / "run_autograder")], env=env, check=True, timeout=600,
                       capture_output=True)
        results = json.loads((root / "results" / "results.json").read_text())
        scores[name] = results["score"]
        assert all({"name", "score", "max_score", "output", "visibility"} <= set(t) for t in results["tests"])
    assert scores["solution"] == 10 and scores["template"] < scores["solution"]


def test_a_link_to_the_hidden_tests_in_a_gradescope_submission_is_left_out(tmp_path):
    from pendkit.grading.gradescope import run

    root = tmp_path / "autograder"
    (root / "submission").mkdir(parents=True)
    (root / "source" / "hidden").mkdir(parents=True)
    (root / "source" / "hidden" / "lab00_hidden.py").write_text("# pendkit-secret-hidden\n")
    notebook = nbformat.read(ROOT / "solutions" / "00_tour.ipynb", as_version=4)
    notebook.cells.append(nbformat.v4.new_code_cell(
        "import os\ndef reward(a, v):\n    raise ValueError(str([open(f).read() for f in os.listdir('.') "
        "if not f.endswith('.ipynb')]))"))
    nbformat.write(notebook, root / "submission" / "00_tour.ipynb")
    os.symlink(root / "source" / "hidden", root / "submission" / "hidden")
    os.symlink(root / "source" / "hidden" / "lab00_hidden.py", root / "submission" / "notes.py")
    result = run(root, "00")
    shown = json.dumps(result)
    assert "pendkit-secret-hidden" not in shown
    assert "left out `hidden` (a symbolic link" in shown and "left out `notes.py` (a symbolic link" in shown
