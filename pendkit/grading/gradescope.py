"""Gradescope's autograder for one lab: `pendkit grade --gradescope-autograder autograder.zip --lab NN`.

The zip follows Gradescope's layout: `setup.sh` (run once when the image is built: Python, bubblewrap,
the CPU build of torch, this kit from the source in the zip) and `run_autograder` (run per submission:
grade `/autograder/submission`, write `/autograder/results/results.json`). The hidden tests travel in the
zip under `hidden/`; Gradescope keeps `/autograder/source` away from the student's code, and the kit's
sandbox hides it again while their notebook runs.
"""

from __future__ import annotations

import json
import shutil
import tempfile
import zipfile
from pathlib import Path

from pendkit.grading.core import load_lab
from pendkit.safe_write import check_no_links, write_text

# pendkit modules that load nbformat are imported inside the functions that use them: importing this module does not
# need them (start-up).

TORCH_VERSION = "2.13.0"
SOURCE_FILES = ("pyproject.toml", "README.md")

SETUP_SH = """#!/usr/bin/env bash
# Gradescope runs this once, as root, when it builds the autograder image.
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends python3 python3-venv python3-pip bubblewrap libegl1 libgl1
python3 -m venv /autograder/venv
/autograder/venv/bin/pip install -q --upgrade pip
# The CPU build of torch first (labs 07-08): an unpinned torch would pull gigabytes of CUDA.
/autograder/venv/bin/pip install -q torch=={torch} --index-url https://download.pytorch.org/whl/cpu
/autograder/venv/bin/pip install -q "/autograder/source/pendkit-src[rl,labs]"
"""

RUN_AUTOGRADER = """#!/usr/bin/env bash
# Gradescope runs this for every submission; AUTOGRADER_ROOT and AUTOGRADER_PYTHON are for local tests.
ROOT="${{AUTOGRADER_ROOT:-/autograder}}"
PYTHON="${{AUTOGRADER_PYTHON:-$ROOT/venv/bin/python}}"
exec "$PYTHON" -m pendkit.cli autograder-run --root "$ROOT" --lab {lab}
"""


def build_autograder(zip_path: Path, lab: str, hidden_dir: Path | None, repo: Path | None = None) -> Path:
    """Write Gradescope's autograder zip for lab `lab`; returns its path."""
    import pendkit

    load_lab(lab)  # fails early with a clear message for a lab without a graded suite
    repo = repo or Path(pendkit.__file__).resolve().parents[1]
    zip_path = Path(zip_path)
    zip_path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(zip_path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, text in (("setup.sh", SETUP_SH.format(torch=TORCH_VERSION)),
                           ("run_autograder", RUN_AUTOGRADER.format(lab=lab))):
            info = zipfile.ZipInfo(name)
            info.external_attr = 0o755 << 16  # executable, as Gradescope expects
            archive.writestr(info, text)
        for name in SOURCE_FILES:
            archive.write(repo / name, f"pendkit-src/{name}")
        package = Path(pendkit.__file__).resolve().parent
        for path in sorted(package.rglob("*")):
            if path.is_file() and "__pycache__" not in path.parts:
                archive.write(path, f"pendkit-src/pendkit/{path.relative_to(package)}")
        for path in sorted(Path(hidden_dir).glob(f"lab{lab}_*.py")) if hidden_dir else []:
            archive.write(path, f"hidden/{path.name}")
    return zip_path


def run(root: Path, lab: str) -> dict:
    """Grade the one submission in `root/submission`; write `root/results/results.json`; return it."""
    from pendkit.grading.report import grade_folder, gradescope_results

    results_dir = root / "results"
    check_no_links(results_dir / "results.json", root)
    with tempfile.TemporaryDirectory() as work:
        grades = grade_folder(root / "submission", Path(work) / "out", lab, root / "source" / "hidden",
                              120.0, 900.0, progress=False, one_student=True)
    if not grades:
        result = {"score": 0.0, "output": f"No notebook found: upload your lab {lab} .ipynb file.", "tests": []}
    else:
        best = max(grades, key=lambda g: g.score)  # several notebooks uploaded: the best one counts
        result = gradescope_results(best)
        if len(grades) > 1:
            result["output"] = f"{len(grades)} notebooks were uploaded; graded {Path(best.notebook).name}.\n" \
                               + result["output"]
    write_text(results_dir / "results.json", json.dumps(result, indent=2) + "\n", base=root)
    return result


def unpack_for_test(zip_path: Path, root: Path) -> Path:
    """Lay the zip out as Gradescope does (`root/source`), for tests and a dry run on your machine."""
    shutil.rmtree(root, ignore_errors=True)
    (root / "submission").mkdir(parents=True)
    with zipfile.ZipFile(zip_path) as archive:
        archive.extractall(root / "source")
    return root
