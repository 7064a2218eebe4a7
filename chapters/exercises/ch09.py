"""Chapter 9 exercises: what accuracy costs in time.

Fill in each function, then run ``python -m tissuefem grade ch09``.
You may use numpy; do not import the answer from tissuefem.

A *setting* of the simulator is measured by two numbers: its cost (ms per
frame) and its error (against a reference). Lists of settings are given as
two 1D sequences of the same length, ``costs`` and ``errors``; a NaN means
the setting failed to run and never counts.
"""

import numpy as np


def pareto_front(costs, errors):
    """Exercise 9.1. The settings worth choosing.

    Setting ``i`` is *dominated* when another setting ``j`` is at least as
    cheap and at least as accurate, and strictly better in one of the two.
    Return the indices of the settings that are not dominated, as a list of
    ints in order of increasing cost. When two settings have exactly the same
    cost and error, keep the one that comes first. Settings with a NaN cost or
    error are never on the front.
    """
    raise NotImplementedError("Exercise 9.1: the Pareto front")


def observed_rates(h, errors):
    """Exercise 9.2. Observed convergence rates between successive meshes.

    If ``error ~ C h^p``, two meshes ``h_i`` and ``h_(i+1)`` give an estimate
    of ``p``. Return a numpy array of ``len(h) - 1`` rates, one per pair of
    successive meshes. Raise ``ValueError`` if the inputs differ in length,
    have fewer than two entries, or contain values that are not finite and
    positive.
    """
    raise NotImplementedError("Exercise 9.2: observed convergence rates")


def best_within_budget(costs, errors, budget):
    """Exercise 9.3. The most accurate setting a frame budget can afford.

    Return the index of the setting with the smallest error among those whose
    cost is at most ``budget``; on equal errors, the cheaper one. Return
    ``None`` when no setting fits the budget.
    """
    raise NotImplementedError("Exercise 9.3: the best setting within a budget")
