"""Lab 07, DQN on the twin: public tests."""

from __future__ import annotations

import numpy as np

from pendkit.grading.core import Diagnosis, Failed, as_number, expect, raised_name, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written

schedule = task("07.epsilon", function="epsilon", title="The exploration schedule", hidden_points=1)
target = task("07.td_target", function="td_target", title="The (double) DQN target", hidden_points=1)
huber = task("07.huber", function="huber", title="The Huber loss", hidden_points=1)


@schedule.test(points=2, hint="Linear from start to end over decay_steps, then constant at end.")
def linear_then_flat(fn, rng):
    for step, expected in [(0, 1.0), (500, 0.525), (1000, 0.05), (5000, 0.05)]:
        got = as_number(fn(step, 1.0, 0.05, 1000), f"epsilon({step}, 1.0, 0.05, 1000)")
        message = f"epsilon({step}, 1.0, 0.05, 1000) should be {expected}, got {got:.4f}"
        if step == 5000 and got < 0.05:
            message += ": stop at the end value; do not keep decreasing"
        elif 0 < abs(got - expected) <= 1.01 * (1.0 - 0.05) / 1000:  # one step's worth of the schedule
            message += Diagnosis(": off by one step; epsilon is `start` at step 0 and reaches `end` at step "
                                 "decay_steps exactly (fraction = step / decay_steps)")
        expect(abs(got - expected) < 1e-9, message)


def _arrays(got, name, n):
    try:
        array = np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        raise Failed(f"{name} should return an array of numbers") from None
    expect(array.shape == (n,), f"{name} should return {n} values, got shape {array.shape}")
    return array


AXIS_HINT = ("next_q_online and next_q_target hold one row per transition and one column per action: take the "
             "max (or argmax) over axis=1, the actions, for one value per transition")


def _along_the_actions(fn, *arguments):
    """fn(*arguments); a shape error from reducing over the batch instead of the actions is named as such."""
    try:
        return fn(*arguments)
    except (IndexError, ValueError) as error:
        if "shape" in str(error) or "broadcast" in str(error):
            raise Failed(f"td_target raised {raised_name(error)}: {error}; {AXIS_HINT}") from None
        raise


# a batch on which every known wrong target differs from the right one and from the others
TELLING_BATCH = (np.array([1.0, -1.0, 0.5]), np.array([0.0, 1.0, 0.0]), np.array([[1.0, 3.0], [2.0, 0.0], [0.0, 1.0]]),
                 np.array([[5.0, 4.0], [9.0, 9.0], [2.0, 7.0]]), 0.9)


@target.test(points=3, hint="The target is r + gamma (1 - done) Q'(s', a'), the future added to the reward; in "
                            "double DQN the online network picks a', the target network values it; no bootstrap "
                            "after a terminal step.")
def double_and_plain_targets(fn, rng):
    rewards, dones, online, target_q, gamma = TELLING_BATCH
    plain = rewards + gamma * (1 - dones) * target_q.max(axis=1)
    double = rewards + gamma * (1 - dones) * target_q[np.arange(3), online.argmax(axis=1)]
    got_double = _arrays(_along_the_actions(fn, rewards, dones, online, target_q, gamma, True),
                         "td_target(..., double=True)", 3)
    got_plain = _arrays(_along_the_actions(fn, rewards, dones, online, target_q, gamma, False),
                        "td_target(..., double=False)", 3)
    message = f"double targets should be {double.tolist()}, got {got_double.tolist()}"
    expect(np.allclose(got_double, double), message + target_note(got_double, rewards, dones, online, target_q,
                                                                   gamma, double=True))
    message = f"plain targets should be {plain.tolist()}, got {got_plain.tolist()}"
    expect(np.allclose(got_plain, plain), message + target_note(got_plain, rewards, dones, online, target_q, gamma,
                                                                double=False))


def target_note(got, rewards, dones, online, target_q, gamma, double: bool) -> str:
    """The cause of a wrong target, when `got` is one of the known wrong ones (a `Diagnosis`), else ""."""
    rows = np.arange(len(rewards))
    pick = online.argmax(axis=1) if double else target_q.argmax(axis=1)
    future = target_q[rows, pick]
    right = rewards + gamma * (1 - dones) * future
    causes = [(rewards - gamma * (1 - dones) * future, ": the sign is wrong; the target is the reward PLUS gamma "
               "times the next state's value (r + gamma (1 - done) Q'), both with a plus sign"),
              (-rewards + gamma * (1 - dones) * future, ": the sign is wrong; the target is the reward PLUS gamma "
               "times the next state's value (r + gamma (1 - done) Q'), both with a plus sign")]
    if double:
        causes += [(rewards + gamma * (1 - dones) * target_q.max(axis=1),
                    ": that is the plain max; let the online network choose the action"),
                   (rewards + gamma * (1 - dones) * online[rows, target_q.argmax(axis=1)],
                    ": the two networks' roles are swapped; the online network picks the action (argmax), the "
                    "target network says what it is worth")]
    causes += [(rewards + gamma * future, ": a terminal step has no future: multiply by (1 - done)"),
               (rewards + gamma * dones * future, ": done is 1 at a terminal step, so (1 - done) keeps the future "
                "where the episode goes on; you kept it only where it ended")]
    got = np.asarray(got, dtype=float)
    named = {cause for wrong, cause in causes
             if got.shape == wrong.shape and np.allclose(got, wrong) and not np.allclose(wrong, right)}
    return Diagnosis(named.pop()) if len(named) == 1 else ""  # a batch that cannot tell two causes apart names none


def target_note_on_a_telling_batch(fn, double: bool) -> str:
    """The cause of a wrong target as the public test's batch shows it (it tells every known cause apart)."""
    rewards, dones, online, target_q, gamma = TELLING_BATCH
    try:
        got = np.asarray(fn(rewards.copy(), dones.copy(), online.copy(), target_q.copy(), gamma, double), dtype=float)
    except Exception:  # noqa: BLE001 (the student's code: the test reports its own failure)
        return ""
    return target_note(got, rewards, dones, online, target_q, gamma, double)


@huber.test(points=2, hint="0.5 e^2 where |e| <= delta, delta (|e| - 0.5 delta) beyond.")
def quadratic_then_linear(fn, rng):
    errors = np.array([0.0, 0.5, -1.0, 2.0, -3.0])
    expected = np.where(np.abs(errors) <= 1.0, 0.5 * errors**2, np.abs(errors) - 0.5)
    got = _arrays(fn(errors, 1.0), "huber(errors, 1.0)", 5)
    message = f"huber({errors.tolist()}, 1.0) should be {expected.tolist()}, got {got.tolist()}"
    expect(np.allclose(got, expected), message + huber_note(got, errors, 1.0))


def huber_note(got, errors, delta: float) -> str:
    """The cause of a wrong Huber loss, when `got` is one of the known wrong ones (a `Diagnosis`), else ""."""
    size = np.abs(errors)
    small = size <= delta
    causes = [(np.where(small, errors**2, delta * (size - 0.5 * delta)),
               ": the quadratic part is half the square, 0.5 e^2 (its slope then meets the linear part's at delta)"),
              (0.5 * errors**2, ": beyond delta the loss grows linearly (that is what makes it robust)"),
              (np.where(small, 0.5 * errors**2, delta * size), ": the linear part is delta (|e| - 0.5 delta): "
               "subtract 0.5 delta in the linear part, so the two pieces meet at |e| = delta (without it the loss "
               "jumps by delta^2 / 2 there)"),
              (np.where(small, 0.5 * errors**2, size), ": the linear part is delta (|e| - 0.5 delta): subtract "
               "0.5 delta in the linear part, so the two pieces meet, and scale it by delta"),
              (np.where(small, 0.5 * errors**2, size - 0.5 * delta), ": the linear part is delta (|e| - 0.5 "
               "delta): it is scaled by delta, so its slope is delta where the quadratic part ends"),
              (np.where(small, 0.5 * errors**2, delta * (size - delta)), ": the linear part subtracts half of "
               "delta, 0.5 delta, not all of it, so the two pieces meet at |e| = delta"),
              (np.where(errors <= delta, 0.5 * errors**2, delta * (errors - 0.5 * delta)),
               ": the size of an error is |e|: a large negative error is beyond delta too (use np.abs)"),
              (np.where(small, 0.5 * errors**2, delta * (errors - 0.5 * delta)),
               ": the linear part needs |e| too, delta (|e| - 0.5 delta): with e it is negative for e < -delta, "
               "and a loss is never negative (its slope there pushes Q away from the target)")]
    got = np.asarray(got, dtype=float)
    right = np.where(small, 0.5 * errors**2, delta * (size - 0.5 * delta))
    for wrong, cause in causes:
        if got.shape == wrong.shape and np.allclose(got, wrong) and not np.allclose(wrong, right):
            return Diagnosis(cause)
    return ""


prelab_task("07", ("epsilon_halfway", "horizon_steps", "double_target"))

written("07.reflection", "Reflection", points=3)


verdict = task("07.policy_verdict", function="policy_verdict",
               title="Judging a policy by the kit's rule", hidden_points=1)
RULE_STARTS = ["rest", "random"] * 5


def _verdict(fn, held, starts, call: str) -> dict:
    got = fn(list(held), list(starts))
    if not isinstance(got, dict) or not {"held", "episodes", "solved"} <= set(got):
        raise Failed(f"{call} should return a dict with held, episodes and solved, got {type(got).__name__}")
    return got


@verdict.test(points=1, hint="Count what held; solved needs at least 9 of 10 (>= 9, so 9 of 10 passes).")
def counts_and_the_threshold(fn, rng):
    for k in (10, 9, 8):
        held = [True] * k + [False] * (10 - k)
        got = _verdict(fn, held, RULE_STARTS, f"policy_verdict({k} of 10 held)")
        expect(got["held"] == k and got["episodes"] == 10,
               f"{k} of 10 held: held should be {k} and episodes 10, got {got['held']} and {got['episodes']}")
        if bool(got["solved"]) != (k >= 9):
            why = _random_starts_alone(fn) or (": at least 9, so 9 passes (>= 9, not > 9)" if k == 9 else "")
            raise Failed(f"{k} of 10 held should {'' if k >= 9 else 'not '}be solved{why}", hint=not why)


def _random_starts_alone(fn) -> str:
    """The cause when a verdict follows the random starts alone (the trap the lab is about), else ""."""
    try:
        only_random = _verdict(fn, [False, True] * 5, RULE_STARTS, "")["solved"]  # 5 of 10: every random start
        miss_on_random = _verdict(fn, [True] * 9 + [False], RULE_STARTS, "")["solved"]  # 9 of 10
        miss_on_rest = _verdict(fn, [False] + [True] * 9, RULE_STARTS, "")["solved"]  # 9 of 10
    except Exception:  # noqa: BLE001 (the student's code: its own failure is reported by the test itself)
        return ""
    if only_random or (miss_on_rest and not miss_on_random):
        return (": the verdict follows the random starts alone; the rule counts all 10 episodes, the 5 hanging "
                "still as much as the 5 random starts")
    return ""


@verdict.test(points=1, hint="One lucky episode is not a policy, and fewer than the rule's 10 episodes (5 of "
                             "each start) never make one solved.")
def one_lucky_episode_is_not_a_policy(fn, rng):
    lucky = [True] + [False] * 9
    got = _verdict(fn, lucky, RULE_STARTS, "policy_verdict(only the first episode held)")
    expect(not got["solved"], "only the first episode (hanging still) held: one lucky episode is not a policy")
    short = _verdict(fn, [True] * 9, RULE_STARTS[:9], "policy_verdict(9 episodes, all held)")
    expect(not short["solved"], "9 episodes, all held, should not be solved: the rule takes 10 episodes, "
                                "5 hanging still and 5 random starts (check how many episodes there were, not "
                                "only how many held)")
    one_kind = _verdict(fn, [True] * 10, ["rest"] * 10, "policy_verdict(10 episodes hanging still, all held)")
    expect(not one_kind["solved"], "10 episodes all from hanging still, all held, should not be solved: the rule "
                                   "takes 5 random starts too (count the starts of each kind)")
    random_alone = _verdict(fn, [True] * 10, ["random"] * 10, "policy_verdict(10 random starts, all held)")
    expect(not random_alone["solved"], "10 episodes all from random starts, all held, should not be solved: the rule "
                                       "takes 5 hanging still too (from random starts alone a policy that never comes "
                                       "up from hanging still looks solved; count the starts of each kind)",
           hint=False)
