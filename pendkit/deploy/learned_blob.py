"""A shipped or trained policy as the blob its rig's device runs: an R-DQN on the paper's readings (layout 1),
or an R-TD3 reading its observers' estimate beside the readings (layout 2, its observers' delays as
`observer_timing` chooses)."""

from __future__ import annotations

from pendkit.agents.learners import DEVICE_LEARNERS
from pendkit.deploy.export import observed_policy_blob, policy_blob
from pendkit.errors import ConfigError

# pendkit modules that load MuJoCo are imported inside the functions that use them: importing this module does not
# need them (start-up).

__all__ = ["DEVICE_LEARNERS", "learned_policy_blob", "observer_timing"]


def learned_policy_blob(spec, state: dict | None, params=None, observer=None, trained_timing=None, run=None,
                        timing=None, source: str = "the policy's weights"):
    """The `PolicyBlob` of a trained agent (`spec`, its policy state) for a rig of `params` (default: the
    learner's own twin). Layout 2: `observer`, the rig or the bank of rigs its observers are designed for
    (default what the laptop would give it on a rig nobody identified, `pendkit.agents.rig_suite`), on the
    delays `observer_timing` chooses; `trained_timing`: the `BackendTiming` its observers had in training
    (default its own twin's); `timing`: the delays to design them for instead (a study's). `run`: (env, agent,
    inputs) already built and loaded, in place of `state` (the env is closed here); `source`: where `state` came
    from, named when it does not fit (`pendkit.agents.run_folder.restore`)."""
    from pendkit.agents.rig_suite import unknown_rig_observer
    from pendkit.agents.run_folder import restore
    from pendkit.agents.runs import build_run

    layout = DEVICE_LEARNERS.get(spec.learner)  # the learner registry's rows say which the device runs
    if layout is None:
        raise ConfigError(f"the device runs {' and '.join(DEVICE_LEARNERS)} policies; this is a {spec.learner} "
                          "run (docs/on-device.md says what exists)")
    if run is None:
        env, agent, inputs = build_run(spec)
        try:
            restore(agent, state, source, policy_only=True)
        except ConfigError:
            env.close()
            raise
    else:
        env, agent, inputs = run
    env.close()
    params = params or env.unwrapped.params
    if layout == 1:
        return policy_blob(agent, params)
    observer = observer or unknown_rig_observer(spec)["observer_params"]
    timing = timing or observer_timing(observer, trained_timing or env.unwrapped.timing)
    return observed_policy_blob(agent, inputs, params, observer, env.unwrapped.filter_coefficient, timing)


def observer_timing(observer, trained_timing):
    """The delays the device's observers are designed for: a bank's own (the device's: it ranks its candidates
    by how well each predicts the readings, which takes the true delays), a single observer's as in training
    (the policy reads that observer's misses as it learned them). On 12 validation rigs: the bank policy 61 of
    72 episodes on the device's delays against 53 on its training's, r-td3-robust 44 against 52
    (docs/results/robust.md)."""
    return None if isinstance(observer, (tuple, list)) and len(observer) > 1 else trained_timing
