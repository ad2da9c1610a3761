"""The grasp study's real-hand scores (`experiments.grasp_recognition.real_grasps.grasp_scores`) against a
hand computation."""
import numpy as np
import pytest

from experiments.grasp_recognition.real_grasps import COARSE_OF_CLASS, grasp_scores


def test_scores_of_four_hands_worked_by_hand():
    predicted = np.array([1, 9, -1, 12])          # Large Diameter, Pinch, not found, Precision Disc
    coarse = np.array(["power", "precision", "power", "precision"])
    exact = np.array([1, -1, 1, 12])               # the second hand's label is none of ours
    s = grasp_scores(predicted, coarse, exact)
    assert s["balanced_accuracy"] == pytest.approx((1 / 2 + 2 / 2) / 2)   # power 1 of 2, precision 2 of 2
    assert s["coarse_accuracy"] == pytest.approx(3 / 4)
    assert s["exact_mean_recall"] == pytest.approx((1 / 2 + 1) / 2)       # class 1: 1 of 2; class 12: 1 of 1
    assert s["found"] == pytest.approx(3 / 4)
    assert (s["power_as_power"], s["power_as_not found"], s["precision_as_precision"]) == (1, 1, 2)


def test_every_class_has_a_coarse_type():
    from sim.grasping import GRASP_CLASSES
    assert set(COARSE_OF_CLASS) == set(GRASP_CLASSES)
