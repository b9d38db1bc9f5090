"""Build student labs from the solution notebooks (the single source), and check they are current.

In `solutions/NN_name.ipynb`:
- code between `### BEGIN SOLUTION` and `### END SOLUTION` becomes a stub that raises NotImplementedError;
- cells tagged `instructor` (notes, expected answers, rubrics) are dropped;
- cells tagged `answer` (a written answer, graded by hand) keep their metadata and get an empty prompt;
- cells tagged `demo` keep the tag (the grader does not run them: `pendkit.grading.runner`);
- `# NBVAL_CHECK_OUTPUT` markers are dropped (a student copy's outputs differ by design);
- outputs and execution counts are cleared; metadata records the lab number for the grader.
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass
from pathlib import Path

import nbformat

from pendkit.errors import ConfigError
from pendkit.grading.written import ANSWER_PROMPT

BEGIN = "### BEGIN SOLUTION"
END = "### END SOLUTION"
INSTRUCTOR_TAG = "instructor"
ANSWER_TAG = "answer"
LAB_NAME = re.compile(r"^(\d\d)_[a-z0-9_]+\.ipynb$")
STUB = 'raise NotImplementedError("not implemented yet: replace this line with your code")'


@dataclass(frozen=True)
class LabFile:
    number: str
    source: Path
    target: Path


def lab_files(solutions_dir: Path, labs_dir: Path) -> list[LabFile]:
    found = []
    for path in sorted(Path(solutions_dir).glob("*.ipynb")):
        match = LAB_NAME.match(path.name)
        if match:
            found.append(LabFile(match.group(1), path, Path(labs_dir) / path.name))
    if not found:
        raise ConfigError(f"no solution notebooks named NN_name.ipynb in {solutions_dir}")
    return found


def strip_solutions(source: str, where: str) -> str:
    """Replace every marked solution block with a stub at the marker's indentation."""
    lines, out, inside, indent = source.splitlines(), [], False, ""
    for number, line in enumerate(lines, start=1):
        stripped = line.strip()
        if stripped == BEGIN:
            if inside:
                raise ConfigError(f"{where}: line {number}: {BEGIN} inside another solution block")
            inside, indent = True, line[: len(line) - len(line.lstrip())]
            out.append(f"{indent}{STUB}")
        elif stripped == END:
            if not inside:
                raise ConfigError(f"{where}: line {number}: {END} without {BEGIN}")
            inside = False
        elif not inside:
            out.append(line)
    if inside:
        raise ConfigError(f"{where}: {BEGIN} is never closed")
    return "\n".join(out)


def student_notebook(solution: nbformat.NotebookNode, lab_number: str, name: str) -> nbformat.NotebookNode:
    """The student copy of a solution notebook."""
    cells = []
    for index, cell in enumerate(solution.cells):
        if INSTRUCTOR_TAG in cell.get("metadata", {}).get("tags", []):
            continue
        new = nbformat.from_dict(json.loads(json.dumps(cell)))
        if new.cell_type == "code":
            source = strip_solutions(new.source, f"{name} cell {index}")
            new.source = "\n".join(line for line in source.splitlines() if line.strip() != "# NBVAL_CHECK_OUTPUT")
            new.outputs, new.execution_count = [], None
        elif BEGIN in new.source:
            raise ConfigError(f"{name} cell {index}: solution markers belong in code cells only")
        elif ANSWER_TAG in new.get("metadata", {}).get("tags", []):
            new.source = ANSWER_PROMPT
        cells.append(new)
    notebook = nbformat.v4.new_notebook(cells=cells)
    notebook.metadata = {
        "kernelspec": {"display_name": "Python 3", "language": "python", "name": "python3"},
        "language_info": {"name": "python"},
        "pendkit": {"lab": lab_number, "source_sha256": hashlib.sha256(
            json.dumps([c.source for c in solution.cells]).encode()).hexdigest()[:16]},
    }
    notebook.nbformat, notebook.nbformat_minor = 4, 5
    for index, cell in enumerate(notebook.cells):
        cell["id"] = f"cell-{index:02d}"  # stable ids: rebuilding gives identical files
    return notebook


def render(notebook: nbformat.NotebookNode) -> str:
    return json.dumps(notebook, indent=1, sort_keys=True, ensure_ascii=False) + "\n"


def build(solutions_dir: Path, labs_dir: Path) -> list[Path]:
    """Write every student lab; return the paths written."""
    Path(labs_dir).mkdir(parents=True, exist_ok=True)
    written = []
    for lab in lab_files(solutions_dir, labs_dir):
        solution = nbformat.read(lab.source, as_version=4)
        lab.target.write_text(render(student_notebook(solution, lab.number, lab.source.name)))
        written.append(lab.target)
    return written


def stale(solutions_dir: Path, labs_dir: Path) -> list[str]:
    """Problems that `build` would fix: missing, outdated or orphaned student labs."""
    problems = []
    expected_names = set()
    for lab in lab_files(solutions_dir, labs_dir):
        expected_names.add(lab.target.name)
        solution = nbformat.read(lab.source, as_version=4)
        wanted = render(student_notebook(solution, lab.number, lab.source.name))
        if not lab.target.exists():
            problems.append(f"{lab.target} is missing")
        elif lab.target.read_text() != wanted:
            problems.append(f"{lab.target} is out of date with {lab.source}")
    for path in sorted(Path(labs_dir).glob("*.ipynb")):
        if path.name not in expected_names:
            problems.append(f"{path} has no solution notebook")
    return problems
