"""The widgets' callbacks as plain functions, the e-stop on a virtual rig, and accessibility basics."""

import time

import numpy as np
import pytest

import pendkit
from pendkit.control.swingup import SwingUpController
from pendkit.episode import PALETTE
from pendkit.link.virtual_rig import LocalRig
from pendkit.widgets import (
    ClassDashboard,
    GainTuner,
    LiveEpisodeView,
    TelemetryMonitor,
    common,
    dashboard_rows,
    tuning_run,
)
from pendkit.widgets.common import trace_alt_text, trace_png
from pendkit.widgets.tuning import balance_png, describe

OKABE_ITO = {"#000000", "#E69F00", "#56B4E9", "#009E73", "#F0E442", "#0072B2", "#D55E00", "#CC79A7", "#999999"}


def test_tuning_reruns_the_twin_with_the_gains():
    good = tuning_run(fidelity="ideal", steps=200)
    timid = tuning_run(energy_gain=0.2, fidelity="ideal", steps=200)
    assert good.time_to_upright_s is not None
    assert timid.time_to_upright_s is None or timid.time_to_upright_s > good.time_to_upright_s
    assert not np.array_equal(good.trace.action, timid.trace.action)


def test_plots_are_png_with_a_text_equivalent():
    result = tuning_run(fidelity="ideal", steps=100)
    assert trace_png(result.trace, "t")[:4] == b"\x89PNG"
    text = trace_alt_text(result.trace, "Swing-up")
    assert "100 steps" in text and "return" in text and "upright" in text


def test_palette_is_colour_blind_safe():
    assert {colour.upper() for colour in PALETTE.values()} <= OKABE_ITO


def test_sliders_are_described_and_update_the_plot(monkeypatch):
    pytest.importorskip("ipywidgets")
    monkeypatch.setattr("pendkit.widgets.tuning.live_frontend", lambda: True)
    tuner = GainTuner(fidelity="ideal", steps=120)
    before = tuner.image.value
    for slider in (tuner.q, tuner.r, tuner.gain):
        assert slider.description and not slider.continuous_update  # labelled; no re-run per pixel
    tuner.gain.value = 3.0  # what a keyboard arrow or a drag does
    assert tuner.image.value != before and "steps" in tuner.text.value


def test_without_a_frontend_widgets_degrade_to_static_output(capsys):
    assert not common.live_frontend()  # no kernel here
    env = pendkit.make(action_mode="continuous", fidelity="ideal", start="rest", filter_coefficient=0.0)
    trace = LiveEpisodeView(env, SwingUpController.for_env(env), title="Swing-up").run(steps=60)
    assert len(trace.time_s) == 61 and "Swing-up: 60 steps" in capsys.readouterr().out


def test_live_view_updates_picture_and_traces_as_it_runs(monkeypatch):
    pytest.importorskip("ipywidgets")
    monkeypatch.setattr("pendkit.widgets.episode_view.live_frontend", lambda: True)
    env = pendkit.make(action_mode="continuous", fidelity="ideal", start="rest", filter_coefficient=0.0)
    view = LiveEpisodeView(env, SwingUpController.for_env(env), title="Swing-up", every=5)
    seen = []
    view.traces.observe(lambda change: seen.append(len(change["new"])), names="value")
    view.run(steps=60)
    assert view.picture.value[:4] == b"\x89PNG"
    assert len(seen) >= 3  # the traces were redrawn during the run (every 20 steps) and at the end
    assert "Swing-up: 60 steps" in view.text.value


def test_dashboard_rows():
    rows = dashboard_rows({"r02": '{"online": true, "flags": 9, "firmware": "0.1.0"}', "r01": "not json"},
                          {"r02": 80, "r03": 10}, 2.0)
    assert [row["rig"] for row in rows] == ["r01", "r02", "r03"]
    assert rows[1] == {"rig": "r02", "online": True, "observations_hz": 40.0, "flags": ["arm_limit", "watchdog"],
                       "firmware": "0.1.0"}
    assert rows[2]["online"] and not rows[0]["online"]


def test_estop_and_telemetry_and_dashboard_on_a_virtual_rig():
    rig = LocalRig()
    try:
        env = pendkit.make(backend="rig", broker=rig.url, rig=rig.rig, rig_options={"reset_stop_s": 0.2})
        env.reset(seed=0)
        monitor = TelemetryMonitor(env)
        for _ in range(5):
            env.step(4)
        summary = monitor.refresh()
        # behaviour, not timing (a busy 2-core machine stretches both; bench_rig_loop.py measures them)
        assert summary["connected"] and summary["observation_age_ms"] >= 0 and summary["step_jitter_p99_ms"] >= 0
        monitor.emergency_stop()
        time.sleep(0.1)
        held = rig.virtual.device.mcu.servo_counts
        for _ in range(5):
            env.step(4)  # "right fast" is replaced by stop while e-stopped
        assert rig.virtual.device.mcu.servo_counts == held and monitor.refresh()["estopped"]
        monitor.release()
        for _ in range(3):
            env.step(4)
        assert rig.virtual.device.mcu.servo_counts > held
        dashboard = ClassDashboard(rig.url)
        time.sleep(1.0)
        rows = dashboard.rows()
        assert rows and rows[0]["rig"] == "r01" and rows[0]["online"] and 30 < rows[0]["observations_hz"] < 50
        dashboard.close()
        env.close()
    finally:
        rig.stop()


def test_q_and_r_visibly_change_the_balance_the_tuner_shows():
    gentle, stiff = tuning_run(pendulum_weight=4.0, steps=250), tuning_run(pendulum_weight=400.0, steps=250)
    assert gentle.balance_error_deg is not None and stiff.balance_error_deg is not None
    assert stiff.arm_travel_deg > 2 * gentle.arm_travel_deg  # a heavier angle weight works the arm harder
    assert abs(stiff.largest_pole - gentle.largest_pole) > 0.01 and not np.allclose(stiff.gain, gentle.gain)
    text = describe(stiff)
    assert "K = [" in text and "largest closed-loop pole" in text and "arm travels over" in text
    assert balance_png(stiff)[:4] == b"\x89PNG"


def test_the_tuners_two_plots_fit_the_notebooks_width(monkeypatch):
    """Both images scale to the notebook's width together: the zoom once ran off the right edge in Chromium."""
    pytest.importorskip("ipywidgets")
    monkeypatch.setattr("pendkit.widgets.tuning.live_frontend", lambda: True)
    tuner = GainTuner(fidelity="ideal", steps=60)
    widths = [float(image.layout.width.rstrip("%")) for image in (tuner.image, tuner.zoom)]
    assert sum(widths) <= 100 and all(image.layout.height == "auto" for image in (tuner.image, tuner.zoom))


def test_the_episode_plot_draws_the_pendulum_without_a_wrap_sawtooth():
    from pendkit.episode import EpisodeTrace, plot_episode

    trace = EpisodeTrace()
    for k, angle in enumerate(np.linspace(0, 6 * np.pi, 120)):  # three whole turns from the bottom
        from_upright = (angle % (2 * np.pi)) - np.pi
        trace.time_s.append(k * 0.06)
        trace.pendulum_from_upright_rad.append(from_upright)
        trace.pendulum_velocity_rad_s.append(1.0)
        trace.arm_angle_rad.append(0.0)
        trace.action.append(0.0)
        trace.reward.append(0.0)
    line = plot_episode(trace).axes[0].get_lines()[0]
    jumps = np.abs(np.diff(line.get_ydata()))
    assert jumps.max() < 20, "the pendulum's line jumps by a full turn at a bottom pass"
