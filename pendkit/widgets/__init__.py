"""Live widgets for demos and tuning (ipywidgets). Each one's logic is a plain function with a unit test;
without a frontend (CI, a script) `show()` prints or displays a static version instead."""

from pendkit.widgets.dashboard import ClassDashboard, dashboard_rows
from pendkit.widgets.episode_view import LiveEpisodeView
from pendkit.widgets.telemetry import TelemetryMonitor, telemetry_summary
from pendkit.widgets.tuning import GainTuner, tuning_run

__all__ = ["ClassDashboard", "GainTuner", "LiveEpisodeView", "TelemetryMonitor", "dashboard_rows",
           "telemetry_summary", "tuning_run"]
