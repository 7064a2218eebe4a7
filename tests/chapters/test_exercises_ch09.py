"""Exercises of chapter 9 (what accuracy costs in time), graded for the library and the student."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from grading import implementations
from tissuefem.workbook import answers

NAN = float("nan")


# --- 9.1 the Pareto front ----------------------------------------------------------------------------

@pytest.mark.parametrize("answer", implementations("ch09", "pareto_front", answers.pareto_front))
def test_ex9_1_hand_made_example(answer):
    #          0     1     2     3    4     5    6
    costs = [10.0, 5.0, 20.0, 5.0, 1.0, 30.0, NAN]
    errors = [1e-3, 1e-2, 1e-4, 2e-2, 1e-1, 1e-4, 1e-9]
    # 3 loses to 1 (same cost, larger error), 5 to 2 (same error, dearer), 6 failed
    assert [int(i) for i in answer(costs, errors)] == [4, 1, 0, 2]


@pytest.mark.parametrize("answer", implementations("ch09", "pareto_front", answers.pareto_front))
def test_ex9_1_ties_and_single_points(answer):
    assert [int(i) for i in answer([1.0], [1.0])] == [0]
    assert [int(i) for i in answer([2.0, 2.0, 1.0], [1.0, 1.0, 3.0])] == [2, 0]


@pytest.mark.parametrize("answer", implementations("ch09", "pareto_front", answers.pareto_front))
@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 6), st.integers(1, 6)), min_size=1, max_size=12))
def test_ex9_1_matches_the_definition(answer, points):
    costs = [float(c) for c, _ in points]
    errors = [float(e) for _, e in points]
    got = [int(i) for i in answer(costs, errors)]
    # brute force from the definition, first of equal points kept
    expected = []
    for i, (c, e) in enumerate(points):
        dominated = any((c2 <= c and e2 <= e and (c2, e2) != (c, e)) or ((c2, e2) == (c, e) and j < i)
                        for j, (c2, e2) in enumerate(points))
        if not dominated:
            expected.append(i)
    assert sorted(got) == sorted(expected)
    assert [costs[i] for i in got] == sorted(costs[i] for i in got)


# --- 9.2 observed rates ------------------------------------------------------------------------------

@pytest.mark.parametrize("answer", implementations("ch09", "observed_rates", answers.observed_rates))
def test_ex9_2_rates(answer):
    h = np.array([0.5, 0.25, 0.125, 0.0625])
    np.testing.assert_allclose(answer(h, 4.0 * h**3), [3.0, 3.0, 3.0])
    errors = [1e-2, 2.6e-3, 6.4e-4]
    np.testing.assert_allclose(answer([0.2, 0.1, 0.05], errors),
                               [math.log2(1e-2 / 2.6e-3), math.log2(2.6e-3 / 6.4e-4)])


@pytest.mark.parametrize("answer", implementations("ch09", "observed_rates", answers.observed_rates))
@pytest.mark.parametrize("h, errors", [([0.1], [1.0]), ([0.1, 0.05], [1.0]), ([0.1, 0.05], [1.0, 0.0]),
                                       ([0.1, -0.05], [1.0, 0.5]), ([0.1, 0.05], [1.0, NAN])])
def test_ex9_2_bad_input(answer, h, errors):
    with pytest.raises(ValueError):
        answer(h, errors)


# --- 9.3 the best setting within a budget --------------------------------------------------------------

@pytest.mark.parametrize("answer", implementations("ch09", "best_within_budget", answers.best_within_budget))
def test_ex9_3_best_within_budget(answer):
    costs = [5.0, 12.0, 30.0, 33.0, 40.0, NAN]
    errors = [1e-2, 1e-3, 2e-4, 2e-4, 1e-6, 1e-9]
    assert answer(costs, errors, 33.0) == 2  # 2 and 3 tie on error: the cheaper
    assert answer(costs, errors, 20.0) == 1
    assert answer(costs, errors, 100.0) == 4
    assert answer(costs, errors, 1.0) is None
