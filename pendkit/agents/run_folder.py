"""A run folder as `pendkit eval`, `export` and `deploy` read it: its weights file (final.pt, else the last
checkpoint.pt), the spec that rebuilds its agent (checked: `pendkit.agents.spec_checks`), and the agent's state
loaded only when every number in it is finite and every tensor fits the agent its spec builds. Anything else
is one ConfigError naming the file, never a traceback or a policy of NaNs."""

from __future__ import annotations

from pathlib import Path

from pendkit.agents.runs import RunSpec, load_weights
from pendkit.errors import ConfigError

WEIGHTS_FILES = ("final.pt", "checkpoint.pt")  # in the order they are preferred


def weights_file(run_dir: str | Path) -> Path:
    """The run's weights: final.pt, else its last checkpoint.pt."""
    run_dir = Path(run_dir)
    for name in WEIGHTS_FILES:
        if (run_dir / name).is_file():
            return run_dir / name
    raise ConfigError(f"no weights in {run_dir} ({' or '.join(WEIGHTS_FILES)}): train one with `pendkit train`")


def load_run(run_dir: str | Path) -> tuple[RunSpec, dict, Path]:
    """(spec, agent state, the weights file it came from)."""
    path = weights_file(run_dir)
    spec, state = load_weights(path)
    return spec, state, path


def first_non_finite(value, where: str = "") -> str | None:
    """Where the first NaN or infinity in an agent's state is (its key path), or None."""
    import numpy as np
    import torch

    if isinstance(value, dict):
        items = value.items()
    elif isinstance(value, (list, tuple)):
        items = enumerate(value)
    elif isinstance(value, torch.Tensor):
        return where if value.is_floating_point() and not bool(torch.isfinite(value).all()) else None
    elif isinstance(value, np.ndarray):
        return where if value.dtype.kind == "f" and not np.isfinite(value).all() else None
    elif isinstance(value, float):
        return where if not np.isfinite(value) else None
    else:
        return None
    for key, item in items:
        found = first_non_finite(item, f"{where}.{key}" if where else str(key))
        if found is not None:
            return found
    return None


def restore(agent, state: dict, source: str, policy_only: bool = False) -> None:
    """Load `state` into `agent` (only its policy with `policy_only`); ConfigError naming `source` (a file, a
    policy) when a number in it is not finite or a tensor's shape is not the agent's."""
    bad = first_non_finite(state)
    if bad is not None:
        raise ConfigError(f"{source}: {bad} holds NaN or infinity (a diverged training?): not loaded")
    try:
        (agent.load_policy if policy_only else agent.load_state_dict)(state)
    except (RuntimeError, KeyError, TypeError, ValueError, AttributeError, IndexError) as error:
        reason = (str(error).strip().splitlines() or [type(error).__name__])
        reason = next((line.strip() for line in reason if "size mismatch" in line), reason[0].strip())
        raise ConfigError(f"{source}: its weights do not fit the agent its spec builds ({reason[:160]})") from None
