"""A trained policy as eval, export, deploy, adapt and the rig queue read it: a shipped policy by name or a run
folder (`pendkit.agents.run_folder`), its spec and weights, the rig it was trained for and the delays its
twin told it (`pendkit.timing` through the twin's fidelity)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pendkit.agents.pretrained import policy_weights
from pendkit.agents.run_folder import load_run
from pendkit.agents.runs import RunSpec
from pendkit.backend_contract import BackendTiming
from pendkit.errors import ConfigError
from pendkit.rig import RigParams
from pendkit.sim.fidelity import resolve_fidelity


@dataclass(frozen=True)
class PolicyArtifact:
    spec: RunSpec
    state: dict
    source: str  # "policy NAME" or the weights file, as messages name it

    @property
    def trained_rig(self) -> RigParams:
        """The rig its twin modelled: the servo preset it was trained on, else the kit's rig."""
        return RigParams.preset(self.spec.preset) if self.spec.preset else RigParams()

    @property
    def timing(self) -> BackendTiming:
        """The delays its twin told it (a realistic twin's: the network's and the device's)."""
        return resolve_fidelity(self.spec.fidelity).timing(self.trained_rig)


def policy_artifact(run_dir: str | Path | None = None, name: str | None = None) -> PolicyArtifact:
    """The policy in `run_dir` (final.pt, else its checkpoint) or the shipped policy `name` (one of them)."""
    if (run_dir is None) == (name is None):
        raise ConfigError("give a run folder or a shipped policy's name (`pendkit policies list`), one of them")
    if name is not None:
        spec, state = policy_weights(name)  # an unknown name: ConfigError with the shipped ones
        return PolicyArtifact(spec, state, f"policy {name}")
    spec, state, path = load_run(run_dir)  # checked: a crafted folder is one line (issue 72)
    return PolicyArtifact(spec, state, str(path))
