import numpy as np
import pytest

import pendkit
from pendkit.errors import ConfigError
from pendkit.network import CLASSROOM_WIFI, IMPAIRMENTS, LatencyModel, NetworkImpairment
from pendkit.sim.fidelity import FIDELITY_PRESETS, Fidelity


def test_default_classroom_latency_percentiles():
    rng = np.random.default_rng(0)
    samples = np.array([CLASSROOM_WIFI.sample_ms(rng) for _ in range(20000)])
    assert samples.min() >= 2.0
    assert np.median(samples) == pytest.approx(8.0, rel=0.05)
    assert 12 < np.percentile(samples, 99) < 30


def test_measured_samples_load_from_csv_and_json(tmp_path):
    csv = tmp_path / "latency.csv"
    csv.write_text("latency_ms\n3.5\n4.0\n12.0\n")
    model = LatencyModel.from_file(csv)
    rng = np.random.default_rng(1)
    assert {model.sample_ms(rng) for _ in range(200)} == {3.5, 4.0, 12.0}
    js = tmp_path / "latency.json"
    js.write_text("[1, 2]")
    assert LatencyModel.from_file(js).samples_ms == (1.0, 2.0)
    (tmp_path / "empty.csv").write_text("header\n")
    with pytest.raises(ConfigError, match="no latency samples"):
        LatencyModel.from_file(tmp_path / "empty.csv")


def staleness_s(fidelity):
    import pendkit

    env = pendkit.make(fidelity=fidelity)
    env.reset(seed=0)
    lags = []
    for _ in range(50):
        info = env.step(0)[4]
        lags.append(info["true_state"]["time_s"] - info["state"].time_s)  # now - when the MCU read it
    return np.array(lags)


def test_measured_latency_drives_the_realistic_twin():
    slow = FIDELITY_PRESETS["realistic"].replace(name="slow-wifi", latency=LatencyModel(samples_ms=(40.0,)))
    slow_lag, default_lag = staleness_s(slow), staleness_s("realistic")
    assert slow_lag.min() >= 0.040 - 1e-9
    assert slow_lag.mean() > default_lag.mean() + 0.025


def test_bad_settings():
    with pytest.raises(ConfigError, match="median_ms"):
        LatencyModel(median_ms=-1)
    with pytest.raises(ConfigError, match="mcu_pipeline"):
        Fidelity("x", network=NetworkImpairment(CLASSROOM_WIFI))


def test_observation_delay_ages_observations_and_leaves_commands_instant():
    import pendkit
    from pendkit.sim.fidelity import observation_delay_fidelity

    slow_lag, fast_lag = staleness_s(observation_delay_fidelity(100)), staleness_s(observation_delay_fidelity(0))
    assert slow_lag.min() >= 0.100 - 1e-9
    assert slow_lag.mean() == pytest.approx(fast_lag.mean() + 0.100, abs=0.0125)  # within half a 25 ms stream period
    true_paths = []
    for delay_ms in (0, 100):
        env = pendkit.make(fidelity=observation_delay_fidelity(delay_ms))
        env.reset(seed=3, options={"start": "rest"})
        true_paths.append([env.step(step % 5)[4]["true_state"]["arm_angle_rad"] for step in range(20)])
    assert np.abs(true_paths[0]).max() > 0.05  # the arm did move
    assert true_paths[0] == true_paths[1]  # the delay is on the way back only: same physics


def test_any_network_imperfection_needs_the_mcu_pipeline():
    for network in (NetworkImpairment(observation_latency=LatencyModel(floor_ms=5)),
                    NetworkImpairment(command_loss_pct=1.0)):
        with pytest.raises(ConfigError, match="mcu_pipeline"):
            Fidelity("x", network=network)


def test_the_twin_and_the_virtual_rig_take_the_same_network_settings():
    """One settings class: a virtual rig's named impairment drives the realistic twin too."""
    import pendkit

    poor = FIDELITY_PRESETS["realistic"].replace(name="poor-wifi", network=IMPAIRMENTS["poor-wifi"])
    env = pendkit.make(fidelity=poor)
    env.reset(seed=0)
    ages = [env.step(0)[4]["state"].observation_age_s for _ in range(200)]
    clean = pendkit.make(fidelity="realistic")
    clean.reset(seed=0)
    clean_ages = [clean.step(0)[4]["state"].observation_age_s for _ in range(200)]
    assert np.mean(ages) > np.mean(clean_ages)  # 3% of readings lost: the newest is older on average
    assert env.unwrapped.timing.reading_delay_s > clean.unwrapped.timing.reading_delay_s


def test_one_path_loses_and_delays_in_order_from_one_stream():
    from pendkit.network import NetworkPath

    lossy = NetworkImpairment(LatencyModel(floor_ms=2.0, median_ms=6.0, spread=0.8), 20.0, 20.0)
    path = NetworkPath(lossy, np.random.default_rng(4))
    arrivals = [path.command_arrival_ms(float(t)) for t in range(0, 2000, 10)]
    kept = [a for a in arrivals if a is not None]
    assert 0.1 < 1 - len(kept) / len(arrivals) < 0.3  # about 20% lost
    assert kept == sorted(kept)  # never overtaking
    assert all(a >= t + 2.0 for a, t in zip(arrivals, range(0, 2000, 10)) if a is not None)
    # without losses no draw is spent on them: the latencies are the stream's own draws, in order
    clean = NetworkPath(NetworkImpairment(LatencyModel(median_ms=5.0, spread=0.5)), np.random.default_rng(9))
    reference = np.random.default_rng(9)
    expected = [1000.0 * k + LatencyModel(median_ms=5.0, spread=0.5).sample_ms(reference) for k in range(5)]
    assert [clean.observation_delivery_ms(1000.0 * k) for k in range(5)] == pytest.approx(expected)


def test_the_twin_and_a_rig_build_their_timing_the_same_way():
    from pendkit.network import median_latency_ms
    from pendkit.timing import host_timing

    env = pendkit.make(fidelity="realistic")
    network = env.unwrapped.backend.fidelity.network
    assert env.unwrapped.timing == host_timing(env.unwrapped.params, env.unwrapped.backend.nominal_step_s,
                                              median_latency_ms(network.latency),
                                              median_latency_ms(network.observation_latency_model))
    assert env.unwrapped.timing.design_delay_s == env.unwrapped.timing.command_delay_s  # an observer runs
    assert pendkit.make().unwrapped.timing.design_delay_s == pendkit.make().unwrapped.timing.loop_delay_s
