"""Classifier scores of the collision benchmark: the best recall at a precision floor, the ROC curve."""

import numpy as np

from latent_planner_ros.models.collision_metrics import auroc, precision_recall, recall_at_precision, roc_curve


def test_recall_at_precision_is_the_best_over_every_threshold(rng):
    labels = rng.random(400) < 0.5
    p = np.clip(0.5 * labels + rng.normal(0.25, 0.25, 400), 0, 1).round(2)  # ties included
    recall, threshold = recall_at_precision(p, labels, 0.88)
    brute = [precision_recall(p, labels, t) for t in np.unique(p)]
    best = max(r for prec, r in brute if prec >= 0.88)
    assert recall == best
    prec, rec = precision_recall(p, labels, threshold)
    assert prec >= 0.88 and rec == recall


def test_recall_at_precision_without_an_answer_is_nan():
    labels = np.array([True, False, True, False])
    assert np.isnan(recall_at_precision(np.array([0.1, 0.9, 0.2, 0.8]), labels, 0.9)[0])
    assert np.isnan(recall_at_precision(np.ones(3), np.ones(3, dtype=bool), 0.5)[0])
    assert recall_at_precision(np.array([0.9, 0.1, 0.8, 0.2]), labels, 0.9) == (1.0, 0.8)


def test_roc_curve_runs_from_origin_to_one_and_its_area_is_the_auroc(rng):
    labels = rng.random(300) < 0.4
    p = np.clip(0.4 * labels + rng.normal(0.3, 0.2, 300), 0, 1).round(2)
    fpr, tpr = roc_curve(p, labels)
    assert (fpr[0], tpr[0], fpr[-1], tpr[-1]) == (0.0, 0.0, 1.0, 1.0)
    assert np.all(np.diff(fpr) >= 0) and np.all(np.diff(tpr) >= 0)
    assert abs(np.trapezoid(tpr, fpr) - auroc(p, labels)) < 1e-9
