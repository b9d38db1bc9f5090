"""Test-run settings shared by the unit tests and the notebooks that nbval runs.

Notebooks run in ci mode (short horizons) with the Agg backend; the kernels inherit this environment.
Solutions run strict: a check short of full marks fails the notebook.
"""

import os
from pathlib import Path

import pytest

os.environ.setdefault("PENDKIT_MODE", "ci")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item):
    # nbval starts a notebook's kernel while setting up its first cell: set strictness before that.
    os.environ["PENDKIT_GRADER_STRICT"] = "1" if "solutions" in Path(str(item.fspath)).parts else "0"
