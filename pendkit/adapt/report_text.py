"""`pendkit adapt`'s report in words: which route to deploy, and report.md from report.json's fields."""

from __future__ import annotations

import math

import numpy as np

from pendkit.deploy.controllers import adapt_controllers

ADAPTED = adapt_controllers()
SWING_UPS = {c.name: c.prose for c in ADAPTED}  # the controllers' names in prose
ROUTES = {"the device design chosen by the trials": ("classical_on_device", "tried"),
          **{f"{c.label} on the rig's device": ("classical_on_device", c.name) for c in ADAPTED},
          "the adapted policy on the rig's device": ("policy_on_device", None),
          "the adapted policy (laptop)": ("policy_on_rig", None),
          **{f"{c.label} (laptop)": ("classical_on_rig", c.name) for c in ADAPTED}}  # in the order ties go


def classical_summaries(report: dict, section: str, joiner: str, labelled: bool = False) -> str:
    """Each adapted controller's summary in `report[section]`, in the registry's order."""
    return joiner.join(f"{c.label + ' ' if labelled else ''}{report[section][c.name]['summary']}" for c in ADAPTED)


def recommended_route(report: dict) -> str | None:
    """The route that solved most of its episodes on the rig (ties: the quicker to upright, then the device's,
    which a busy room's WiFi does not reach); None when none solved any."""
    scored = []
    for order, (route, (section, name)) in enumerate(ROUTES.items()):
        result = report.get(section, {}) if name is None else report[section].get(name, {})
        solved = result.get("solved", [])
        times = [t for t, ok in zip(result.get("upright_s", []), solved) if ok and t is not None]
        if any(solved):
            scored.append((-sum(solved), float(np.median(times)) if times else math.inf, order, route))
    return min(scored)[3] if scored else None


def device_policy_markdown(report: dict) -> str:
    blob = report.get("device_policy_blob")
    return f" (`pendkit deploy --blob {blob} --rig ID`)" if blob else ""


def trials_markdown(report: dict) -> str:
    chosen = report.get("chosen_design")
    if not chosen:
        return ""
    if not report["device_trials"]:
        return (f"Device design: the identified twin's {SWING_UPS[chosen['controller']]} swing-up, without trials. "
                f"To run it: `pendkit deploy --blob {report['device_blob']} --rig ID`.\n\n")
    tried = report["classical_on_device"].get("tried", {}).get("summary", "not evaluated")
    return (f"Device trials ({report['rig_s_trials']:.0f} s of rig time, {len(report['device_trials'])} designs): "
            f"the {chosen['controller']} swing-up designed for the {chosen['label']} servo held best; "
            f"evaluated: {tried}. To run it: `pendkit deploy --blob {report['device_blob']} --rig ID`.\n\n")


def wall_clock_markdown(report: dict) -> str:
    budget = report["config"].get("budget_s")
    cut = report.get("budget_cut") or []
    return (f"Wall clock: every route ready after {report['wall_s_adaptation']:.0f} s"
            + (f" (budget {budget:.0f} s{'; it cut ' + '; '.join(cut) if cut else ''})" if budget else "")
            + (f", {report['wall_s_total']:.0f} s with the evaluation." if "wall_s_total" in report else "."))


def refinement_markdown(report: dict) -> str:
    refined = report.get("servo_refined")
    if not refined:
        return ""
    before, after = refined["before"], report["identified"]
    return (f"The servo refined over {refined['loop_episodes']} loop episodes as well: full-torque error "
            f"{before['servo_full_torque_error_deg']:.2f} -> {after['servo_full_torque_error_deg']:.2f} deg, "
            f"damping ratio {before['servo_damping_ratio']:.2f} -> {after['servo_damping_ratio']:.2f}, speed "
            f"{before['servo_speed_s_per_60deg']:.3f} -> {after['servo_speed_s_per_60deg']:.3f} s/60 deg.\n\n")


def candidates_markdown(report: dict) -> str:
    rows = report.get("candidates_on_twin")
    if not rows:
        return ""
    def on_device(row: dict) -> str:
        held = row.get("held_on_device")
        return "-" if held is None else f"{held}/{row['episodes']}"

    lines = "\n".join(f"| {row['policy']} | {row['stage']} | {row['held']}/{row['episodes']} | "
                      f"{row['mean_return']:.0f} | {on_device(row)} |" for row in rows)
    return ("The starting policies judged on the identified twin by the kit's rule (the best from the laptop went "
            "to the rig; the best run by the rig's device, on its twin with no network, to the device):\n\n"
            "| policy | stage | held | mean return | held, run by the device |\n|---|---|---|---|---|\n" + lines
            + "\n\n")


def _allowed(row: dict | None) -> str:
    return "-" if row is None else f"{row['low']:.4g} .. {row['high']:.4g}"


def network_markdown(report: dict) -> str:
    return f" The twin ran behind the network the logs show: {report['network']}." if "network" in report else ""


def report_markdown(report: dict) -> str:
    uncertain = report.get("uncertain", {})
    rows = "\n".join(f"| {name} | {report['prior'].get(name, float('nan')):.4g} | {value:.4g} | "
                     f"{_allowed(uncertain.get(name))} |" for name, value in report["identified"].items())
    untrusted = report.get("untrusted")
    return (f"# Adaptation of {report['rig']}\n\n"
            + (f"**Deployed from an identification not trusted** (`--deploy-untrusted`): {untrusted}\n\n"
               if untrusted else "") +
            f"Rig time: {report['rig_s_adaptation']:.0f} s to adapt ({report['rig_s_excitation']:.0f} s of "
            f"excitation), {report['rig_s_total']:.0f} s with the evaluation. {wall_clock_markdown(report)}\n\n"
            f"| parameter | prior | identified | the recordings allow (the twin's training) |\n|---|---|---|---|\n"
            f"{rows}\n\n{refinement_markdown(report)}"
            f"Matching cost (mean squared angle error, rad^2): prior {report['matching_cost']['prior']:.4f}, "
            f"identified {report['matching_cost']['identified']:.4f}. Encoder: the hanging pendulum read "
            f"{report.get('encoder_recalibrated_counts', 0):+d} counts"
            f"{'' if not report.get('encoder_recalibrated_counts') else '; its zero was moved by as much'}."
            f"{network_markdown(report)}\n\n"
            f"On the rig: the adapted policy {report['policy_on_rig']['summary']} from the laptop and "
            f"{report.get('policy_on_device', {}).get('summary', 'not evaluated')} run by the rig's own device"
            f"{device_policy_markdown(report)}; designed on the identified twin, "
            f"{classical_summaries(report, 'classical_on_rig', ', ', labelled=True)} (run from the laptop); the same "
            f"designs run by the rig's own device: {classical_summaries(report, 'classical_on_device', ' and ')}.\n\n"
            f"{trials_markdown(report)}{candidates_markdown(report)}"
            f"Deploy: {report['recommended'] or 'none of them solved this rig'}.\n\n"
            "![recorded and simulated swings](identification.png)\n")
