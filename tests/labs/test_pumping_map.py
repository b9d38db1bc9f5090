"""Lab 05: the map of the student's pumping direction shows a missing cos(alpha), which the swing-up itself
does not (the controller asks the rule about a small swing, below the horizontal)."""

import math

from pendkit.labs.pumping_map import direction_grid, disagreement_lines, right_direction

W0 = 5.3


def test_the_right_rule_matches_everywhere():
    assert "everywhere" in " ".join(disagreement_lines(*direction_grid(right_direction, W0)))


def test_a_rule_without_the_cosine_is_named_above_the_horizontal():
    lines = disagreement_lines(*direction_grid(lambda angle, rate: -1 if rate > 0 else 1, W0))
    assert "0 % of the map below the horizontal" in lines[0] and "cos(alpha) missing" in lines[1], lines


def test_a_braking_rule_is_named():
    braking = direction_grid(lambda angle, rate: 1 if rate * math.cos(angle) > 1e-9 else -1, W0)
    assert "brakes the swing" in " ".join(disagreement_lines(*braking))


def test_a_rule_that_slips_only_where_nothing_moves_names_the_convention_not_a_share():
    for rule, gives in ((lambda angle, rate: -1 if rate * math.cos(angle) > 0 else 1, "gives -1 only"),
                        (lambda angle, rate: -1 if rate * math.cos(angle) > 1e-9 else
                         (1 if rate * math.cos(angle) < -1e-9 else 0), "gives 0 only")):
        lines = disagreement_lines(*direction_grid(rule, W0))
        assert len(lines) == 1 and gives in lines[0] and "the lab asks for +1 there" in lines[0], lines
        assert "%" not in lines[0], lines
