"""`pendkit adapt`: fit the kit to one rig in a few of its episodes (docs/adapt.md)."""

from __future__ import annotations

from pathlib import Path

import click

from pendkit.cli.broker_login import broker_login_options, login_from
from pendkit.cli.learning import torch_or_exit
from pendkit.errors import ConfigError, IdentificationError, RecordingError
from pendkit.link import DEFAULT_BROKER
from pendkit.rig import RigParams

# pendkit modules that load MuJoCo, matplotlib, python-control and paho-mqtt are imported inside the functions that
# use them: importing this module does not need them (`pendkit --help` stays quick).


@click.command()
@click.option("--backend", type=click.Choice(("rig", "sim")), default="rig", show_default=True,
              help="rig: a (virtual) rig over MQTT; sim: a hidden twin from --params (tests, rehearsals).")
@click.option("--rig", "rig_id", default="r01", show_default=True)
@click.option("--broker", default=None, help=f"With --backend rig (default {DEFAULT_BROKER}).")
@click.option("--params", "params_path", type=click.Path(exists=True, dir_okay=False, path_type=Path), default=None,
              help="With --backend sim: the hidden rig (RigParams.save's format).")
@click.option("--impairment", type=click.Choice(("none", "classroom-wifi", "poor-wifi")), default="classroom-wifi",
              show_default=True, help="With --backend sim: the hidden rig's network.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path), required=True)
@click.option("--episodes", type=click.IntRange(1, 100), default=10, show_default=True,
              help="The rig's time adaptation may use, in episodes of 500 steps (30 s each: 10 is 5 minutes): "
                   "excitation (3 to 6 short ones, 18 to 35 s, as many as the recordings need), device trials if "
                   "asked for, fine-tuning (--fine-tune) in the whole episodes left.")
@click.option("--fine-tune/--no-fine-tune", default=False, show_default=True,
              help="Fine-tune the policy on the rig in what the budget leaves; without: the excitation alone "
                   "(fine-tuning lost rigs the twin's choice held, docs/results/robust.md).")
@click.option("--twin-episodes", type=click.IntRange(0), default=60, show_default=True,
              help="Training episodes on the identified twin (laptop time).")
@click.option("--twin-tolerance", type=click.FloatRange(0), default=1.0, show_default=True,
              help="Train on a rig drawn each episode from what the recordings allow: the matching cost within "
                   "(1 + this) of the fit's; 0: the identified rig alone.")
@click.option("--evaluate", "evaluation_episodes", type=click.IntRange(0), default=3, show_default=True,
              help="Greedy episodes on the rig afterwards, for the policy and for the classical controllers.")
@click.option("--policy", "policy_name", default="r-td3-robust", show_default=True,
              help="The shipped policy to start from (an observer it reads stays as it was trained: designed for "
                   "the identified rig for td3-robust, for the nominal rig for r-td3-robust); a learner's name "
                   "(e.g. td3+estimated) trains afresh until the rule holds on the identified twin.")
@click.option("--candidate", "candidates", multiple=True,
              help="A further shipped policy to start from (repeatable; default r-td3-bank-robust; none: --policy "
                   "alone): each, and --policy, "
                   "as shipped and after the twin's training, is judged on the identified twin by the kit's rule, "
                   "and the one that holds most goes to the rig.")
@click.option("--measured-network/--fixed-latency", default=True, show_default=True,
              help="Run the identified twin behind the network the excitation logs show (the readings' delays "
                   "and losses) rather than a fixed latency with no loss.")
@click.option("--device-trials/--no-device-trials", default=False, show_default=True,
              help="Try the device's designs for five servo loops on the rig first (3.5 minutes of its time); "
                   "without: the identified twin's minimum-time design, which did as well (docs/results/transfer.md).")
@click.option("--loop-episodes", type=click.IntRange(0, 10), default=None,
              help="Short excitation episodes of small quick steps that show the servo's loop (4 s of rig time each); "
                   "the servo is then refined over them (default: AdaptConfig's).")
@click.option("--identification-restarts", "restarts", type=click.IntRange(1, 10), default=3, show_default=True,
              help="Identify up to this many times from the same recordings (laptop time only, a search starting "
                   "only when it can end within a fifth of --budget-s) "
                   "and keep the twin that matches them best.")
@click.option("--deploy-untrusted", is_flag=True, default=False,
              help="Deploy even from an identification whose matching cost is hardly better than a pendulum that "
                   "never moved (without: its report and figure, nothing deployable, exit 1).")
@click.option("--budget-s", type=click.FloatRange(0), default=300.0, show_default=True,
              help="Wall seconds from the start until every route is ready (identification, designs, the "
                   "learned route's training), the rig's evaluation episodes after it; a smaller budget trains "
                   "less (the first identification search and each policy's as-shipped verdict always run), and "
                   "the end of the run says what it cut. 0: no limit.")
@click.option("--seed", type=int, default=0, show_default=True)
@broker_login_options
def adapt(backend, rig_id, broker, params_path, impairment, out_dir, episodes, fine_tune, twin_episodes, twin_tolerance,
          evaluation_episodes, policy_name, candidates, measured_network, device_trials, loop_episodes, restarts,
          deploy_untrusted, budget_s, seed, username, password, tls_ca) -> None:
    """Fit the kit to one rig in a few of its episodes: excite it, identify its twin from the encoder, design
    the device's swing-up for it, train on that twin, fine-tune on the rig; report every route."""
    torch_or_exit()
    from pendkit.adapt.rigs import mqtt_rig, twin_rig
    from pendkit.adapt.session import AdaptConfig
    from pendkit.adapt.session import adapt as run_adaptation

    try:  # the settings checked before the rig is reached
        config = AdaptConfig(episodes=episodes, excitation_episodes=min(6, episodes), fine_tune=fine_tune,
                             twin_episodes=twin_episodes,
                             twin_tolerance=twin_tolerance or None,
                             evaluation_episodes=evaluation_episodes, policy=policy_name,
                             candidates=chosen_candidates(candidates), measured_network=measured_network,
                             device_trials=device_trials, identification_restarts=restarts, seed=seed,
                             deploy_untrusted=deploy_untrusted, budget_s=budget_s or None,
                             min_excitation_episodes=min(3, episodes),
                             **({} if loop_episodes is None else {"loop_episodes": loop_episodes}))
        if backend == "sim":
            if params_path is None:
                raise click.UsageError("--backend sim needs --params RIG.json (the hidden rig)")
            rig = twin_rig(RigParams.load(params_path), impairment)
        else:
            rig = mqtt_rig(rig_id, broker, login_from(username, password, tls_ca))
        report = run_adaptation(rig, out_dir, config, say=click.echo)
    except (ConfigError, IdentificationError) as error:
        raise click.ClickException(str(error)) from None
    except RecordingError as error:  # refused before anything was written
        raise click.ClickException(f"{error} (nothing written to {out_dir})") from None
    click.echo(f"rig time {report['rig_s_adaptation']:.0f} s to adapt, every route ready after "
               f"{report['wall_s_adaptation']:.0f} s, {report['wall_s_total']:.0f} s with the evaluation on the rig; "
               f"report in {out_dir / 'report.md'}")
    click.echo(f"policy: {report['policy_on_rig']['summary']}")


def chosen_candidates(given: tuple[str, ...]) -> tuple[str, ...]:
    """--candidate as given ("none" for no candidate), or AdaptConfig's when it was not given."""
    from pendkit.adapt.session import AdaptConfig

    return tuple(name for name in given if name != "none") if given else AdaptConfig.candidates


COMMANDS = (adapt,)
