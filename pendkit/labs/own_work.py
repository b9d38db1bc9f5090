"""A student's functions from an earlier lab's notebook beside this one (lab 09 uses the swing-up from the
student's own lab 05): the cells that define them run in a namespace of their own, and a function that is
still a stub, or that raises, counts as absent."""

from __future__ import annotations

import math
from pathlib import Path

import nbformat
import numpy as np

SWING_UP_FUNCTIONS = ("pendulum_energy", "pumping_direction", "next_mode")
_PREAMBLE = "import math\nimport numpy as np\n"


def functions_from(notebook: str | Path, names: tuple[str, ...]) -> dict | None:
    """The named functions as the notebook defines them (with the constants in their cells), or None when the
    notebook is not there or one of them is missing."""
    path = Path(notebook)
    if not path.is_file():
        return None
    namespace: dict = {}
    exec(_PREAMBLE, namespace)  # noqa: S102 - the student's own notebook, in the student's own kernel
    for cell in nbformat.read(path, as_version=4).cells:
        if cell.cell_type == "code" and any(f"def {name}(" in cell.source for name in names):
            try:
                exec(cell.source, namespace)  # noqa: S102
            except Exception:
                return None
    found = {name: namespace.get(name) for name in names}
    return found if all(callable(fn) for fn in found.values()) else None


def own_swing_up_parts(folder: str | Path = "."):
    """`SwingUpParts` from the student's lab 05 notebook in `folder` (05_swingup.ipynb), and a sentence saying
    what is used; the kit's parts (None) when it is absent, unfinished or broken."""
    from pendkit.control.swingup import SwingUpParts

    path = Path(folder) / "05_swingup.ipynb"
    found = functions_from(path, SWING_UP_FUNCTIONS)
    if found is None:
        return None, f"{path.name} is not beside this notebook (or not finished): using the kit's swing-up"
    try:  # one probe each: a stub raises NotImplementedError, a broken one something else
        float(found["pendulum_energy"](0.1, 0.2, 5.0))
        float(found["pumping_direction"](0.1, 0.2))
        found["next_mode"]("swing", 0.1, 0.2)
    except Exception as error:
        name = type(error).__name__
        return None, f"your lab 05 functions do not run yet ({name}): using the kit's swing-up"
    if not np.isfinite(float(found["pendulum_energy"](math.pi, 0.0, 5.0))):
        return None, "your lab 05 energy is not finite: using the kit's swing-up"
    parts = SwingUpParts(energy=found["pendulum_energy"], direction=found["pumping_direction"],
                         next_mode=found["next_mode"])
    return parts, f"using your swing-up from {path.name} (its energy, direction and hand-over)"
