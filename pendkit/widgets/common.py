"""What every widget shares: PNG figures with alt text, and knowing whether a live frontend is there."""

from __future__ import annotations

import io
import os

from pendkit.episode import EpisodeTrace, plot_episode
from pendkit.features import UPRIGHT_RAD


def live_frontend() -> bool:
    """True in a Jupyter kernel with widgets available and not in a CI or grading run."""
    if os.environ.get("PENDKIT_MODE", "interactive") != "interactive":
        return False
    try:
        import ipywidgets  # noqa: F401
        from IPython import get_ipython
    except ImportError:
        return False
    shell = get_ipython()
    return shell is not None and getattr(shell, "kernel", None) is not None


def figure_png(figure) -> bytes:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=80)
    return buffer.getvalue()


def trace_png(trace: EpisodeTrace, title: str, natural_frequency_rad_s: float | None = None) -> bytes:
    return figure_png(plot_episode(trace, title=title, natural_frequency_rad_s=natural_frequency_rad_s))


def trace_alt_text(trace: EpisodeTrace, title: str) -> str:
    """A one-line description of an episode plot, for screen readers (shown beside the image)."""
    data = trace.as_arrays()
    import numpy as np

    near_top = float(np.mean(np.abs(data["pendulum_from_upright_rad"]) < UPRIGHT_RAD))
    return (f"{title}: {len(data['time_s']) - 1} steps over {data['time_s'][-1]:.1f} s; return "
            f"{trace.episode_return:.1f}; within {UPRIGHT_RAD:g} rad of upright {100 * near_top:.0f}% of the time.")
