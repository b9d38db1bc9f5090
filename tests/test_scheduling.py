"""The suite's own scheduling: files that wait on real time run beside computing ones, not beside each other."""

from pathlib import Path

from tests.scheduling import WAITS_ON_REAL_TIME, lanes_for, next_file

ROOT = Path(__file__).resolve().parents[1]
WAITS = ("rig.py", "notebook.ipynb")


def test_a_free_lane_takes_the_first_waiting_file_even_behind_computing_ones():
    assert next_file(["train.py", "identify.py", "rig.py", "notebook.ipynb"], 0, 1, WAITS) == "rig.py"


def test_with_every_lane_waiting_the_next_file_computes():
    assert next_file(["rig.py", "train.py", "notebook.ipynb", "identify.py"], 1, 1, WAITS) == "train.py"
    assert next_file(["notebook.ipynb", "identify.py"], 1, 2, WAITS) == "notebook.ipynb"


def test_when_only_waiting_files_are_left_they_run_whatever_the_lanes():
    assert next_file(["notebook.ipynb", "rig.py"], 3, 1, WAITS) == "notebook.ipynb"
    assert next_file(["train.py"], 0, 1, WAITS) == "train.py"


def test_the_workers_beyond_the_cores_wait_on_real_time():
    assert lanes_for(workers=3, cores=2) == 1
    assert lanes_for(workers=4, cores=2) == 2
    assert lanes_for(workers=1, cores=2) == 1


def test_every_file_said_to_wait_on_real_time_exists():
    missing = [path for path in WAITS_ON_REAL_TIME if not (ROOT / path).is_file()]
    assert not missing, f"renamed or removed: update tests/scheduling.py ({missing})"
