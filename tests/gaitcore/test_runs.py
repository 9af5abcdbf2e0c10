"""Runs of True: the stretches every frame mark (steady gait, stance, frames to check) uses."""

from __future__ import annotations

import numpy as np

from gaitcore.runs import true_runs


def test_runs_of_true_in_order_with_the_stop_excluded():
    assert true_runs([False, True, True, False, True]) == [(1, 3), (4, 5)]
    assert true_runs(np.ones(4, bool)) == [(0, 4)]
    assert true_runs(np.zeros(4, bool)) == [] and true_runs([]) == []
