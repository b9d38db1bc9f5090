"""Where a student's kernel runs while `pendkit grade` runs their notebook: a bubblewrap sandbox.

Why bubblewrap: it is a small, well-kept Debian/Ubuntu/Fedora package (the sandbox behind Flatpak) that
builds Linux namespaces without a daemon or root. Inside, the kernel sees a read-only system and Python,
only the kit's own package of this checkout, and a scratch folder with a copy of the submission: no
hidden tests, solutions, other submissions or grades folder exist there. It has no network, its own
process tree (everything it started, detached or not, dies with it) and limits on CPU time, memory,
file size and (for a normal user) processes. The kernel talks to the grader over Unix sockets in the
scratch folder. Where bubblewrap is missing (macOS, Windows, WSL without it) `pendkit grade` says that
isolation is off and grades anyway: docs/labs-and-grading.md.
"""

from __future__ import annotations

import functools
import json
import os
import platform
import shutil
import site
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

KERNEL_NAME = "pendkit-sandbox"
SYSTEM_DIRS = ("/usr", "/etc", "/lib", "/lib64", "/lib32", "/bin", "/sbin", "/opt/conda")


@dataclass(frozen=True)
class Limits:
    cpu_s: int = 1200
    memory_mb: int = 8192  # address space: torch and MuJoCo reserve far more than they use
    file_mb: int = 512
    processes: int = 256  # beyond the user's own (only where the grader is not root)


@functools.cache
def isolation_problem() -> str | None:
    """Why a sandbox cannot be used here, or None when it can."""
    if platform.system() != "Linux":
        return f"bubblewrap needs Linux (this is {platform.system()})"
    if shutil.which("bwrap") is None:
        return "bubblewrap is not installed (sudo apt-get install bubblewrap)"
    probe = subprocess.run(["bwrap", *_namespace_args(), "--ro-bind", "/", "/", "true"], capture_output=True,
                           text=True, timeout=30)
    if probe.returncode != 0:
        return f"bubblewrap cannot create namespaces here ({probe.stderr.strip()[:120]})"
    return None


def _namespace_args() -> list[str]:
    user = [] if os.geteuid() == 0 else ["--unshare-user"]
    return [*user, "--unshare-pid", "--unshare-net", "--unshare-ipc", "--unshare-uts", "--die-with-parent",
            "--new-session", "--cap-drop", "ALL"]


def _python_dirs() -> list[str]:
    import pendkit

    dirs = {sys.prefix, sys.base_prefix, sys.exec_prefix, str(Path(pendkit.__file__).resolve().parent),
            str(Path(sys.executable).resolve().parent.parent), *site.getsitepackages()}
    return sorted(d for d in dirs if Path(d).exists())


def _process_cap(extra: int) -> int:
    """RLIMIT_NPROC counts all of a user's processes: theirs now plus `extra`. Root ignores it (0: none)."""
    if os.geteuid() == 0:
        return 0
    uid = os.geteuid()
    mine = 0
    for entry in Path("/proc").iterdir():
        try:
            mine += entry.name.isdigit() and entry.stat().st_uid == uid
        except OSError:
            continue
    return mine + extra


class Sandbox:
    """A scratch folder holding a copy of the submission's folder, and a kernel spec that starts the kernel
    inside bubblewrap. `kernel_manager()` for nbclient; `close()` removes the scratch folder."""

    def __init__(self, submission_dir: Path, limits: Limits | None = None) -> None:
        self.limits = limits or Limits()
        self.root = Path(tempfile.mkdtemp(prefix="pendkit-grade-"))
        self.work = self.root / "work"
        shutil.copytree(submission_dir, self.work, ignore=shutil.ignore_patterns(".ipynb_checkpoints"))
        for name in ("home", "specs", "run"):
            (self.root / name).mkdir()
        self._write_spec()

    def _write_spec(self) -> None:
        binds: list[str] = []
        for path in SYSTEM_DIRS:
            binds += ["--ro-bind-try", path, path]
        for path in _python_dirs():
            binds += ["--ro-bind", path, path]
        home = str(self.root / "home")
        argv = ["bwrap", *_namespace_args(), "--dev", "/dev", "--proc", "/proc", "--tmpfs", "/tmp", *binds,
                "--bind", str(self.root), str(self.root), "--chdir", str(self.work),
                "--setenv", "HOME", home, "--setenv", "MPLCONFIGDIR", home, "--setenv", "IPYTHONDIR", home,
                "--unsetenv", "JPY_PARENT_PID",  # its parent is the sandbox's init (pid 1): no parent polling
                sys.executable, "-m", "pendkit.grading.sandbox_launch", "--cpu-s", str(self.limits.cpu_s),
                "--memory-mb", str(self.limits.memory_mb), "--file-mb", str(self.limits.file_mb),
                "--nproc", str(_process_cap(self.limits.processes)), "--", "-f", "{connection_file}"]
        spec = {"argv": argv, "display_name": "pendkit sandbox", "language": "python",
                "interrupt_mode": "message",  # a signal would reach bwrap, not the kernel inside it
                "env": {"PYTHONNOUSERSITE": "1"}}
        folder = self.root / "specs" / KERNEL_NAME
        folder.mkdir()
        (folder / "kernel.json").write_text(json.dumps(spec, indent=1))

    def kernel_manager(self):
        """A kernel manager for one run of the notebook (a restart gets a fresh one)."""
        from jupyter_client.kernelspec import KernelSpecManager
        from jupyter_client.manager import AsyncKernelManager

        specs = KernelSpecManager(kernel_dirs=[str(self.root / "specs")], ensure_native_kernel=False)
        run = self.root / "run"
        return AsyncKernelManager(kernel_name=KERNEL_NAME, kernel_spec_manager=specs, transport="ipc",
                                  ip=str(run / "kernel"), connection_file=str(run / "connection.json"))

    def close(self) -> None:
        shutil.rmtree(self.root, ignore_errors=True)
