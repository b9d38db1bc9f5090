from pathlib import Path

import pytest

from pendkit.grading import load_hidden, load_lab

ROOT = Path(__file__).resolve().parents[2]
HIDDEN = ROOT / "solutions" / "tests"


@pytest.fixture(scope="session")
def all_tests_loaded():
    """Public and hidden tests of every lab, loaded once."""
    for lab in sorted(path.name[3:5] for path in HIDDEN.glob("lab??_hidden.py")):
        load_lab(lab)
        for path in sorted(HIDDEN.glob(f"lab{lab}_*.py")):
            load_hidden(path)
    return True

