from pathlib import Path

import pytest

from pendkit.grading import load_hidden, load_lab

ROOT = Path(__file__).resolve().parents[2]
HIDDEN = ROOT / "solutions" / "tests"


@pytest.fixture(scope="session")
def all_tests_loaded():
    """Public and hidden tests of labs 00-02, loaded once."""
    for lab in ("00", "01", "02"):
        load_lab(lab)
        for path in sorted(HIDDEN.glob(f"lab{lab}_*.py")):
            load_hidden(path)
    return True

