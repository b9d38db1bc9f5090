"""The rig's network read from the excitation logs (both clocks per reading), and the identified twin run
behind it."""

import dataclasses

import numpy as np
import pytest

from pendkit.adapt.identify import Identification
from pendkit.adapt.network_fit import measured_network
from pendkit.adapt.replay import DeviceTrace
from pendkit.adapt.routes import identified_twin
from pendkit.adapt.uncertainty import AroundTheFit
from pendkit.network import IMPAIRMENTS, LatencyModel, NetworkImpairment
from pendkit.rig import RigParams
from tests.adapt.test_replay import HIDDEN, logged_recordings


def test_a_lossy_jittery_wifi_is_read_from_the_logs_and_a_clean_link_is_read_as_clean(tmp_path):
    poor = IMPAIRMENTS["poor-wifi"]  # 3% lost each way, 4 ms + lognormal(15 ms, 0.8)
    found = measured_network(logged_recordings(HIDDEN, poor, tmp_path / "poor", episodes=3), latency_ms=19.0)
    samples = np.asarray(found.latency.samples_ms)
    assert 1.5 <= found.observation_loss_pct <= 5.0 and found.command_loss_pct == found.observation_loss_pct
    assert np.median(samples) == pytest.approx(19.0, abs=1.0)  # centred on the latency identification found
    rng = np.random.default_rng(0)
    true = np.array([poor.latency.sample_ms(rng) for _ in range(5000)])
    assert np.percentile(samples, 90) == pytest.approx(np.percentile(true, 90), rel=0.35)  # its tail, not a floor
    clean = measured_network(logged_recordings(HIDDEN, IMPAIRMENTS["none"], tmp_path / "clean", episodes=1), 5.0)
    assert clean.observation_loss_pct == 0 and np.allclose(clean.latency.samples_ms, 5.0, atol=1e-6)


def test_recordings_without_the_hosts_clock_measure_nothing(tmp_path):
    recordings = logged_recordings(HIDDEN, IMPAIRMENTS["classroom-wifi"], tmp_path, episodes=1)
    for recording in recordings:
        recording.device = dataclasses.replace(recording.device, host_ms=())  # a recording made before it was kept
    assert measured_network(recordings, 10.0) is None
    trace = DeviceTrace((0.0, 25.0), (0.0, 0.0), (1500, 1500), (), (3.0, 28.0))
    assert DeviceTrace.from_dict({**trace.as_dict(), "host_ms": []}).host_ms == ()  # an older excitation.json


def test_the_identified_twin_and_its_training_rigs_run_behind_the_measured_network():
    measured = NetworkImpairment(LatencyModel(samples_ms=(8.0, 30.0, 90.0)), 2.0, 2.0)
    fit = Identification(RigParams(), 10.0, 0.0, 0.0, 0, 0.0, network=measured)
    env = identified_twin(fit)
    assert env.unwrapped.backend.fidelity.network == measured
    drawn = AroundTheFit(env, fit, {"servo_speed_s_per_60deg": (0.1, 0.2)}, seed=0).draw()
    assert drawn[1] == measured and 0.1 <= drawn[0].servo_speed_s_per_60deg <= 0.2
    env.close()
    fixed = identified_twin(dataclasses.replace(fit, network=None))
    assert fixed.unwrapped.backend.fidelity.network.latency == LatencyModel(floor_ms=10.0)  # the default as before
    fixed.close()
