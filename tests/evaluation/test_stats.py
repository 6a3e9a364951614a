import pytest

from bimanualshift.evaluation.stats import wilson_interval


def test_wilson_interval_known_values() -> None:
    lo, hi = wilson_interval(5, 10)
    assert lo == pytest.approx(0.2366, abs=1e-4) and hi == pytest.approx(0.7634, abs=1e-4)
    assert wilson_interval(0, 20)[0] == 0.0 and wilson_interval(20, 20)[1] == pytest.approx(1.0)


def test_wilson_interval_rejects_bad_counts() -> None:
    with pytest.raises(ValueError):
        wilson_interval(3, 0)
    with pytest.raises(ValueError):
        wilson_interval(4, 3)


def test_paired_sign_test_counts_disagreements_and_matches_the_binomial_tail() -> None:
    from scipy.stats import binomtest

    from bimanualshift.evaluation.stats import paired_sign_test

    a = [True] * 15 + [False] * 5 + [True] * 30 + [False] * 10
    b = [False] * 15 + [True] * 5 + [True] * 30 + [False] * 10
    result = paired_sign_test(a, b)
    assert (result.pairs, result.a_wins, result.b_wins) == (60, 15, 5)
    assert result.p_value == pytest.approx(binomtest(5, 20, 0.5).pvalue)
    assert paired_sign_test([True, False], [True, False]).p_value == 1.0  # no disagreement: no evidence
    with pytest.raises(ValueError, match="same count"):
        paired_sign_test([True], [True, False])


def test_pair_by_scene_keeps_the_scenes_both_ran_in_order() -> None:
    from bimanualshift.evaluation.stats import pair_by_scene

    a = {("lift_ball", "none", 3): True, ("lift_ball", "none", 1): False, ("pick_up_plate", "none", 1): True}
    b = {("lift_ball", "none", 1): True, ("lift_ball", "none", 3): True, ("lift_ball", "none", 7): False}
    scenes, flags_a, flags_b = pair_by_scene(a, b)
    assert scenes == [("lift_ball", "none", 1), ("lift_ball", "none", 3)]  # a scene only one side ran is left out
    assert (flags_a, flags_b) == ([False, True], [True, True])
    assert pair_by_scene({10: True, 9: False}, {9: True, 10: True})[0] == [9, 10]  # seeds sort as numbers
    assert pair_by_scene({1: True}, {2: True}) == ([], [], [])
