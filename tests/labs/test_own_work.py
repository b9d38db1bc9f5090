"""Lab 09 uses the student's own lab 05 swing-up when it is beside it, and says so; the kit's otherwise."""

import shutil
from pathlib import Path

from pendkit.labs.own_work import own_swing_up_parts

ROOT = Path(__file__).resolve().parents[2]


def test_a_finished_lab_05_beside_lab_09_supplies_the_swing_up(tmp_path):
    shutil.copy(ROOT / "solutions" / "05_swingup.ipynb", tmp_path)
    parts, said = own_swing_up_parts(tmp_path)
    assert parts is not None and "your swing-up" in said
    assert parts.energy(0.0, 0.0, 5.0) == -1.0 and parts.next_mode("swing", 0.1, 0.2) == "balance"


def test_an_unfinished_or_absent_lab_05_leaves_the_kits_swing_up(tmp_path):
    parts, said = own_swing_up_parts(tmp_path)
    assert parts is None and "not beside this notebook" in said
    shutil.copy(ROOT / "labs" / "05_swingup.ipynb", tmp_path)  # the student copy: stubs
    parts, said = own_swing_up_parts(tmp_path)
    assert parts is None and "do not run yet (NotImplementedError)" in said


def test_the_students_own_mistake_is_what_lab_09_runs(tmp_path):
    import nbformat

    notebook = nbformat.read(ROOT / "solutions" / "05_swingup.ipynb", as_version=4)
    for cell in notebook.cells:
        if "def pumping_direction(" in cell.source:
            cell.source = ("def pumping_direction(angle_from_bottom_rad, velocity_rad_s):\n"
                           "    return 1 if velocity_rad_s * math.cos(angle_from_bottom_rad) > 0 else -1\n")
    nbformat.write(notebook, tmp_path / "05_swingup.ipynb")
    parts, _ = own_swing_up_parts(tmp_path)
    assert parts.direction(0.1, 1.0) == 1  # the reversed rule, as the student wrote it
