"""Hidden tests for lab 07 (instructor material: never copied into labs/)."""

import numpy as np
import torch

from pendkit.grading import expect, task
from pendkit.grading.core import Diagnosis, as_number
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab07 import huber_note, target_note, target_note_on_a_telling_batch

schedule = task("07.epsilon", function="epsilon", title="The exploration schedule")
huber = task("07.huber", function="huber", title="The Huber loss")


@schedule.test(points=1, hidden=True, hint="It must agree with pendkit's DQN schedule.")
def matches_the_kit(fn, rng):
    from pendkit.agents.dqn import DqnAgent, DqnConfig

    agent = DqnAgent(2, 2, DqnConfig(epsilon_start=0.8, epsilon_end=0.1, epsilon_decay_steps=300))
    for step in (0, 150, 299, 300, 1000):
        agent.steps = step
        got = as_number(fn(step, 0.8, 0.1, 300), f"epsilon({step}, 0.8, 0.1, 300)")
        message = f"epsilon({step}, 0.8, 0.1, 300) should be {agent.epsilon:.4f} as the kit's DQN has it, got {got:.4f}"
        if 0 < abs(got - agent.epsilon) <= 1.01 * (0.8 - 0.1) / 300:  # one step's worth of the schedule
            message += Diagnosis(": off by one step; epsilon is `start` at step 0 and reaches `end` at step "
                                 "decay_steps exactly (fraction = step / decay_steps)")
        expect(abs(got - agent.epsilon) < 1e-9, message)


@huber.test(points=1, hidden=True, hint="Any delta; it must agree with torch's huber_loss.")
def matches_torch(fn, rng):
    errors = rng.normal(0, 3, 50)
    for delta in (0.5, 2.0):
        expected = torch.nn.functional.huber_loss(torch.tensor(errors), torch.zeros(50), reduction="none",
                                                  delta=delta).numpy()
        got = np.asarray(fn(errors, delta), dtype=float)
        expect(got.shape == expected.shape and np.allclose(got, expected),
               f"50 random errors with delta={delta} do not match torch's huber_loss" + huber_note(got, errors, delta))


target = task("07.td_target", function="td_target", title="The (double) DQN target")


@target.test(points=1, hidden=True, hint="Any batch size, any number of actions, terminal steps included.")
def random_batches(fn, rng):
    for batch, actions in ((1, 2), (7, 5), (32, 3)):
        rewards, dones = rng.normal(size=batch), (rng.random(batch) < 0.3).astype(float)
        online, target_q, gamma = rng.normal(size=(batch, actions)), rng.normal(size=(batch, actions)), 0.97
        for double in (True, False):
            next_value = (target_q[np.arange(batch), online.argmax(axis=1)] if double else target_q.max(axis=1))
            expected = rewards + gamma * (1 - dones) * next_value
            got = np.asarray(fn(rewards, dones, online, target_q, gamma, double), dtype=float).reshape(-1)
            expect(got.shape == expected.shape and np.allclose(got, expected),
                   f"td_target on a batch of {batch} with {actions} actions (double={double}): expected "
                   f"{np.round(expected, 4).tolist()[:3]}, got {np.round(got, 4).tolist()[:3]}"
                   + (target_note_on_a_telling_batch(fn, double)
                      or target_note(got, rewards, dones, online, target_q, gamma, double)))


prelab_answers("07", {"epsilon_halfway": 0.525, "horizon_steps": 100.0, "double_target": 1.085},
               where="Each question gives its numbers; the background's double-DQN paragraph says which network "
                     "picks the next action and which values it.")


verdict = task("07.policy_verdict", function="policy_verdict", title="Judging a policy by the kit's rule")


@verdict.test(points=1, hidden=True, hint="The rule needs 5 starts of each kind; any order of held episodes.")
def any_order_and_both_kinds_of_start(fn, rng):
    starts = ["rest", "random"] * 5
    for _ in range(20):
        held = list(rng.random(10) < 0.85)
        got = fn(held, starts)
        expect(got["held"] == sum(held) and bool(got["solved"]) == (sum(held) >= 9),
               f"{sum(held)} of 10 held: got held {got['held']}, solved {got['solved']}")
    only_rest = fn([True] * 10, ["rest"] * 10)
    expect(not only_rest["solved"], "10 episodes all hanging still is not the rule: it takes 5 random starts too")
    twice = fn([True] * 20, starts * 2)
    expect(not twice["solved"], "20 episodes, all held, should not be solved: the rule is exactly 10 episodes, 5 of "
                                "each start (a longer run is not the rule; run the rule's 10)", hint=False)


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def policy_verdict(held, starts, strict=False, lucky=False, share=False):
    held, starts = [bool(h) for h in held], list(starts)
    complete = len(held) == 10 and starts.count("rest") == 5 and starts.count("random") == 5
    if lucky:
        solved = held[0]
    elif share:
        solved = sum(held) >= 0.9 * len(held)
    else:
        solved = complete and (sum(held) > 9 if strict else sum(held) >= 9)
    return {"held": sum(held), "episodes": len(held), "solved": solved}


def td_target(rewards, dones, online_q, target_q, gamma, double, mask_terminal=True):
    rows = np.arange(len(rewards))
    future = target_q[rows, online_q.argmax(axis=1)] if double else target_q.max(axis=1)
    return rewards + gamma * (1 - dones if mask_terminal else 1) * future


CORRECT = {
    "07.epsilon": lambda step, start, end, decay: end + (start - end) * max(0.0, 1 - step / decay),
    "07.td_target": lambda r, done, online, target, gamma, double: td_target(r, done, online, target, gamma, double),
    "07.huber": lambda e, delta: np.where(np.abs(e) <= delta, 0.5 * e**2, delta * (np.abs(e) - 0.5 * delta)),
    "07.policy_verdict": lambda held, starts: policy_verdict(held, starts),
}

MISTAKES = [
    ("07.epsilon", lambda step, start, end, decay: start + (end - start) * step / decay, "stop at the end value"),
    ("07.td_target", lambda r, done, on, tq, g, double: td_target(r, done, on, tq, g, False), "plain max"),
    ("07.td_target", lambda r, done, on, tq, g, double: td_target(r, done, on, tq, g, double, False), "no future"),
    ("07.huber", lambda e, delta: 0.5 * np.asarray(e) ** 2, "grows linearly"),
    ("07.huber", lambda e, delta: np.where(np.abs(e) <= delta, 0.5 * e**2, np.abs(e)), "subtract 0.5 delta"),
    ("07.huber", lambda e, delta: np.where(np.abs(e) <= delta, 0.5 * e**2, delta * np.abs(e)), "subtract 0.5 delta",
     {"quadratic_then_linear", "matches_torch"}),
    ("07.huber", lambda e, delta: np.where(np.abs(e) <= delta, 0.5 * e**2, delta * (np.abs(e) - delta)),
     "not all of it", {"matches_torch"}),
    ("07.policy_verdict", lambda held, starts: {"held": sum(map(bool, held)), "episodes": len(held), "solved": len(
        held) >= 10 and list(starts).count("rest") >= 5 and list(starts).count("random") >= 5
        and sum(map(bool, held)) >= 0.9 * len(held)}, "exactly 10 episodes"),
    ("07.policy_verdict", lambda held, starts: policy_verdict(held, starts, strict=True), "9 passes"),
    ("07.policy_verdict", lambda held, starts: policy_verdict(held, starts, lucky=True), "one lucky episode"),
    ("07.policy_verdict", lambda held, starts: policy_verdict(held, starts, share=True), "the rule takes 10"),
    ("07.td_target", lambda r, done, online, target, gamma, double: td_target(r, 1 - np.asarray(done), online,
                                                                               target, gamma, double),
     "kept it only where it ended", {"double_and_plain_targets", "random_batches"}),
    ("07.td_target", lambda r, done, online, target, gamma, double: td_target(r, done, target, online, gamma, double)
     if double else td_target(r, done, online, target, gamma, double), "roles are swapped"),
    ("07.td_target", lambda r, done, online, target, gamma, double: np.asarray(r) + gamma * (1 - np.asarray(done))
     * np.asarray(target).max(axis=0), "over axis=1, the actions"),
    ("07.epsilon", lambda step, start, end, decay: start + (end - start) * min(1.0, (step + 1) / decay), "off by one",
     {"linear_then_flat", "matches_the_kit"}),
    ("07.huber", lambda e, delta: np.where(np.abs(e) <= delta, np.asarray(e) ** 2, delta * (np.abs(e) - 0.5 * delta)),
     "half the square"),
    ("07.policy_verdict", lambda held, starts: {"held": sum(map(bool, held)), "episodes": len(held),
                                                "solved": sum(map(bool, held)) >= 9}, "the rule takes 10 episodes"),
    ("07.policy_verdict", lambda held, starts: {"held": sum(map(bool, held)), "episodes": len(held),
                                                "solved": len(held) == 10 and sum(map(bool, held)) >= 9},
     "5 random starts too"),
    ("07.policy_verdict", lambda held, starts: {"held": sum(map(bool, held)), "episodes": len(held), "solved": all(
        ok for ok, start in zip(held, starts) if start == "random")}, "random starts alone"),
    ("07.policy_verdict", lambda held, starts: {"held": sum(map(bool, held)), "episodes": len(held), "solved": len(
        held) == 10 and sum(map(bool, held)) >= 9 and all(ok for ok, s in zip(held, starts) if s == "random")},
     "random starts alone"),
    ("07.td_target", lambda r, done, online, target, gamma, double: 2 * np.asarray(r, dtype=float)
     - td_target(r, done, online, target, gamma, double), "the sign is wrong"),
    ("07.huber", lambda e, delta: np.where(np.abs(e) <= delta, 0.5 * np.asarray(e) ** 2,
                                           delta * (np.asarray(e) - 0.5 * delta)), "needs |e| too",
     {"quadratic_then_linear", "matches_torch"}),
    ("07.policy_verdict", lambda held, starts: {"held": sum(map(bool, held)), "episodes": len(held), "solved": len(
        held) == 10 and list(starts).count("random") >= 5 and sum(map(bool, held)) >= 9}, "5 hanging still too",
     {"one_lucky_episode_is_not_a_policy"}),
]
